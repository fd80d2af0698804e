"""``wheelnav bench codec``: encoding and decoding each busy message type, against msgpack.

Every message the fleet sends is checked field by field as it is encoded and again as it
is decoded (:mod:`shared.codec`). This bench times both for the types a lockstep tick
carries, built as the fleet builds them (a VLP-16 scan of 25,600 points, a path of 40
waypoints), next to the named peer: ``msgpack.packb`` / ``unpackb`` of the same map with
no checks at all. The ratio is what the checks and the message objects cost on top of
msgpack. Figures are the fastest of several batches (microseconds per message).
"""

from __future__ import annotations

import argparse
import json
import timeit
from collections.abc import Callable

import msgpack
import numpy as np

from shared import messages as m
from shared.codec import decode, encode

REPEATS = 7


def busy_messages() -> dict[str, m.Msg]:
    """One message of each type a lockstep tick carries, at the fleet's sizes."""
    rng = np.random.default_rng(0)
    pose = m.Pose2D(3.25, -1.5, 0.7, "1")
    waypoints = np.column_stack([np.linspace(0.0, 8.0, 40), np.zeros(40)])
    return {
        "clock": m.Clock(12.34, 617, 0.02, 1),
        "ack": m.Ack("controller", 617, 618, 0.0031),
        "twist": m.Twist(12.34, 0.45, -0.1),
        "odometry": m.Odometry(12.34, pose, 0.45, -0.1),
        "pose estimate": m.PoseEstimate(12.34, pose, np.eye(3) * 1e-4),
        "follow status": m.FollowStatus(12.34, "route-1.0", "following", 0.65, 1.1, 0.01),
        "path (40 points)": m.Path(12.0, "route-1.0", "1", waypoints, np.full(40, 0.5)),
        "scan (25,600 points)": m.PointCloud(
            12.34, "lidar", rng.uniform(-20.0, 20.0, size=(25_600, 3)).astype(np.float32)
        ),
    }


def _fastest_us(fn: Callable[[], object], number: int) -> float:
    return min(timeit.repeat(fn, number=number, repeat=REPEATS)) / number * 1e6


def run_codec_bench(batch: int = 2000) -> list[dict[str, float | str]]:
    """Per message type: payload bytes, encode and decode us, msgpack alone us (``batch``
    messages a timing, a fortieth of it for a scan)."""
    rows: list[dict[str, float | str]] = []
    for name, msg in busy_messages().items():
        payload = encode(msg)
        wire = msgpack.unpackb(payload, raw=False)  # the same map, arrays as extension types
        kind = type(msg)
        number = max(1, batch // 40) if len(payload) > 100_000 else batch
        rows.append(
            {
                "message": name,
                "bytes": len(payload),
                "encode_us": _fastest_us(lambda msg=msg: encode(msg), number),
                "decode_us": _fastest_us(lambda p=payload, t=kind: decode(p, t), number),
                "msgpack_pack_us": _fastest_us(lambda w=wire: msgpack.packb(w), number),
                "msgpack_unpack_us": _fastest_us(
                    lambda p=payload: msgpack.unpackb(p, raw=False), number
                ),
            }
        )
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="wheelnav bench codec", description=__doc__.splitlines()[0]
    )
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    args = parser.parse_args(argv)
    rows = run_codec_bench()
    if args.json:
        print(json.dumps(rows))
        return 0
    print("us per message (fastest of 7 batches); peer: msgpack alone, no checks")
    print(
        f"{'message':22s} {'bytes':>8s} {'encode':>8s} {'msgpack':>8s} {'ratio':>6s}"
        f" {'decode':>8s} {'msgpack':>8s} {'ratio':>6s}"
    )
    for r in rows:
        print(
            f"{r['message']:22s} {r['bytes']:8d} {r['encode_us']:8.1f} "
            f"{r['msgpack_pack_us']:8.1f} {r['encode_us'] / r['msgpack_pack_us']:6.1f}"
            f" {r['decode_us']:8.1f} {r['msgpack_unpack_us']:8.1f}"
            f" {r['decode_us'] / r['msgpack_unpack_us']:6.1f}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
