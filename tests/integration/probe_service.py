"""A minimal service for the diagnostics test: the Service base and one subscription.

Run by the supervisor as ``python -m tests.integration.probe_service --connect ENDPOINT``;
it listens for Twists on the robot's ``cmd_vel`` key and does nothing with them.
"""

from __future__ import annotations

from shared.messages import Twist
from shared.service import Service


def main(argv: list[str] | None = None) -> None:
    with Service("probe", __doc__.splitlines()[0], argv) as svc:
        svc.bus.subscribe(svc.declare("subscribes", svc.keys.cmd_vel), Twist, lambda _m: None)
        svc.wait()


if __name__ == "__main__":
    main()
