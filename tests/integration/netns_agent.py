"""A Zenoh client the test drives from another network namespace, over stdin and stdout.

Run as ``python -m tests.integration.netns_agent --connect ENDPOINT [--security DIR --user
NAME]`` (under ``ip netns exec``). It prints ``ready`` once its session is open (or
``refused: <why>`` and exits 1), then takes one JSON command a line:
``{"sub": KEY}`` subscribes and prints every sample as ``{"key": KEY, "hex": PAYLOAD}``;
``{"put": KEY, "hex": PAYLOAD}`` publishes. It stops at the end of its input.
"""

from __future__ import annotations

import argparse
import json
import sys
import threading

from shared.config import SecurityConfig, TransportConfig
from shared.transport import Bus, open_session


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--connect", required=True)
    parser.add_argument("--security", default="")
    parser.add_argument("--user", default="")
    args = parser.parse_args(argv)
    transport = TransportConfig(connect=[args.connect], security=SecurityConfig(args.security))
    try:
        bus = Bus(open_session(transport, args.user), f"agent-{args.user or 'anonymous'}")
    except RuntimeError as exc:
        print(f"refused: {exc}", flush=True)
        return 1
    lock = threading.Lock()

    def say(line: dict) -> None:
        with lock:
            print(json.dumps(line), flush=True)

    print("ready", flush=True)
    for line in sys.stdin:
        command = json.loads(line)
        if "sub" in command:
            bus.subscribe_raw(command["sub"], lambda k, p: say({"key": k, "hex": p.hex()}))
        elif "put" in command:
            bus.session.put(command["put"], bytes.fromhex(command["hex"]))
    bus.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
