"""motocell: run and watch simulated Yaskawa Motoman cells that ROS-Industrial's
motoman_driver drives as it would a controller running MotoROS."""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence

from services.launcher import __main__ as launcher
from shared.service import version
from tools import bench, credentials, demo, fault, observe, plot, record


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="motocell", description=__doc__, allow_abbrev=False)
    parser.add_argument("--version", action="version", version=f"motocell {version()}")
    commands = parser.add_subparsers(dest="command", required=True)

    up = commands.add_parser("up", help="run a whole cell in the foreground")
    launcher.add_arguments(up)
    up.set_defaults(run=launcher.run)

    fault.add_parser(commands)
    observe.add_parsers(commands)
    record.add_parser(commands)
    plot.add_parser(commands)
    bench.add_parser(commands)
    credentials.add_parser(commands)

    router = commands.add_parser(
        "router", help="a Zenoh router (a stand-in for zenohd where its image is not available)"
    )
    launcher.add_router_arguments(router)
    router.set_defaults(run=launcher.router)

    run_demo = commands.add_parser(
        "demo", help="start a cell and drive it like motoman_driver does, then stop it"
    )
    run_demo.add_argument("--host", default="127.0.0.1")
    run_demo.add_argument("--port-base", type=int, help="use a running cell at this port base")
    run_demo.add_argument("--config", help="cell TOML file for the cell the demo starts")
    run_demo.add_argument("--points", type=int, default=20)
    run_demo.add_argument("--duration", type=float, default=2.0, help="trajectory seconds")
    run_demo.set_defaults(run=demo.run)
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
