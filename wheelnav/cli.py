"""The ``wheelnav`` command: run the fleet, run missions, and look at topics.

wheelnav up [--profile sim|hardware]     the whole fleet around a local router
wheelnav mission SCENARIO.yaml           one mission, with a report
wheelnav campaign [--buildings N]        generated buildings x missions: table, figures
wheelnav go PLACE [--wait] | cancel | status   the mission API on a live fleet
wheelnav stop [--clear] | resume         emergency stop (every layer), resume a paused mission
wheelnav topic list|echo KEY|hz KEY      look at live topics (--connect for a remote chair)
wheelnav viz --connect tcp/CHAIR:7447    stream a running fleet to a rerun viewer (--viewer URL)
wheelnav compose [--check]               docker-compose.yml from the fleet definition
wheelnav security init DIR | add | show  credentials for a secured fleet (docs/security.md)
wheelnav bench planner [--json]          performance figures against a named peer
wheelnav plan MAP --start X,Y --goal X,Y  a route on a map, without the fleet (--json, --png)
wheelnav rooms MAP [--floor F]           a floor's rooms and doors (--json, --png)
wheelnav warm                            compile the numba kernels before a first start
"""

from __future__ import annotations

import argparse
import sys

from shared.config import ConfigError


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="wheelnav",
        description=__doc__.splitlines()[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="\n".join(__doc__.splitlines()[2:]),
    )
    sub = parser.add_subparsers(dest="command", required=True)
    from wheelnav import mission_api
    from wheelnav import stop as stop_cli
    from wheelnav import warm as warm_cli
    from wheelnav.bench import cli as bench_cli
    from wheelnav.campaign import runner as campaign_runner
    from wheelnav.launcher import cli as launcher_cli
    from wheelnav.maptools import cli as maptools_cli
    from wheelnav.mission import cli as mission_cli
    from wheelnav.security import cli as security_cli
    from wheelnav.topic_tools import cli as topic_cli

    launcher_cli.add_commands(sub)
    mission_cli.add_commands(sub)
    mission_api.add_commands(sub)
    stop_cli.add_commands(sub)
    topic_cli.add_commands(sub)
    topic_cli.add_tree_command(sub)
    bench_cli.add_commands(sub)
    campaign_runner.add_commands(sub)
    maptools_cli.add_commands(sub)
    security_cli.add_commands(sub)
    warm_cli.add_commands(sub)
    raw = list(sys.argv[1:] if argv is None else argv)
    args = parser.parse_args(raw)
    args.raw_argv = raw  # for commands that hand their flags on to a service as given
    try:
        return int(args.run(args) or 0)
    except ConfigError as exc:
        print(f"wheelnav: {exc}", file=sys.stderr)
        return 2
    except RuntimeError as exc:  # e.g. no router at the endpoint given
        print(f"wheelnav: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:  # output piped into head and the like: stop quietly
        sys.stderr.close()
        return 0


if __name__ == "__main__":
    sys.exit(main())
