"""The viz service's choice of where the stream goes, as flags: kept apart from the node so
that ``wheelnav viz`` lists them without loading rerun."""

from __future__ import annotations

import argparse


def add_sink_arguments(parser: argparse.ArgumentParser) -> None:
    """Where the stream goes (one of them; none: spawn a native viewer on this machine)."""
    sink = parser.add_mutually_exclusive_group()
    sink.add_argument("--save", metavar="FILE.rrd", help="record to a file")
    sink.add_argument("--serve", action="store_true", help="serve a web viewer")
    sink.add_argument("--viewer", metavar="URL", help="connect to a running rerun viewer")
