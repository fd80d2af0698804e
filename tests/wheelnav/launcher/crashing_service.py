"""A service for the in-process fleet's test: it starts, announces itself, and then its
main raises, as a service with a bug would."""

from __future__ import annotations

from shared.service import Service


def main(argv: list[str] | None = None) -> None:
    with Service("crasher", "raises once it is up", argv) as svc:
        svc.ready()
        raise RuntimeError("boom: a bug in a service")
