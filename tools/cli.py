"""motocell: run and watch simulated Yaskawa Motoman cells that ROS-Industrial's
motoman_driver drives as it would a controller running MotoROS."""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence

from services.launcher import __main__ as launcher
from shared.service import version
from tools import bench, credentials, demo, echo, fault, hz, observe, plot, record


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="motocell", description=__doc__, allow_abbrev=False)
    parser.add_argument("--version", action="version", version=f"motocell {version()}")
    commands = parser.add_subparsers(dest="command", required=True)

    up = commands.add_parser("up", help="run a whole cell in the foreground")
    launcher.add_arguments(up)
    up.set_defaults(run=launcher.run)

    fault.add_parser(commands)
    observe.add_parsers(commands)
    echo.add_parser(commands)
    hz.add_parser(commands)
    record.add_parser(commands)
    plot.add_parser(commands)
    bench.add_parser(commands)
    credentials.add_parser(commands)

    router = commands.add_parser(
        "router", help="a Zenoh router (a stand-in for zenohd where its image is not available)"
    )
    launcher.add_router_arguments(router)
    router.set_defaults(run=launcher.router)

    demo.add_parser(commands)
    for subcommand in commands.choices.values():
        # No abbreviated options anywhere: `--port-bas` must not silently mean `--port-base`.
        subcommand.allow_abbrev = False
    return parser


def main(argv: Sequence[str] | None = None) -> None:
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s motocell %(levelname)s %(message)s")
    sys.exit(args.run(args))


if __name__ == "__main__":
    main()
