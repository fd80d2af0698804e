"""The flags every service shares: what a session is told to connect to."""

from __future__ import annotations

import argparse

from shared.service import add_transport_arguments, config_from_args


def parsed(*argv: str):
    parser = argparse.ArgumentParser()
    add_transport_arguments(parser)
    return config_from_args(parser.parse_args(list(argv)))


def test_a_router_started_by_hand_links_only_where_told() -> None:
    # a router session now also uses transport.connect (links to other hosts' routers);
    # `--mode router` alone must not link it to the default client endpoint
    assert parsed("--mode", "router").transport.connect == []
    linked = parsed("--mode", "router", "--connect", "tcp/10.0.0.2:7447")
    assert linked.transport.connect == ["tcp/10.0.0.2:7447"]
    assert parsed().transport.connect == ["tcp/127.0.0.1:7447"]  # a client: the default
