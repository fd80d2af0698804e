"""``wheelnav bench codec``: every busy message type timed, next to msgpack alone."""

from __future__ import annotations

from shared.codec import decode, encode
from wheelnav.bench.codec import busy_messages, run_codec_bench


def test_the_bench_messages_are_valid_and_round_trip() -> None:
    for msg in busy_messages().values():
        assert encode(decode(encode(msg), type(msg))) == encode(msg)


def test_every_message_is_timed_with_its_peer() -> None:
    rows = run_codec_bench(batch=20)
    assert [r["message"] for r in rows] == list(busy_messages())
    for r in rows:
        assert r["bytes"] > 0
        for key in ("encode_us", "decode_us", "msgpack_pack_us", "msgpack_unpack_us"):
            assert 0 < r[key] < 1e5, (r["message"], key, r[key])
    scan = rows[-1]
    assert scan["bytes"] > 25_600 * 12  # raw float32 points, not msgpack numbers
