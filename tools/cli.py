"""The ``motocell`` command."""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence

from services.launcher import launcher
from shared.service import add_zenoh_arguments
from tools import bench, demo, fault, observe, plot, record


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="motocell", description=__doc__)
    commands = parser.add_subparsers(dest="command", required=True)

    up = commands.add_parser("up", help="run a whole cell in the foreground")
    up.add_argument("--config", help="cell TOML file (default: one 6-axis arm on a YRC1000)")
    up.add_argument("--host", help="address the TCP ports listen on (default 127.0.0.1)")
    up.add_argument("--port-base", type=int, help="motion port (default 50240); state +1, I/O +2")
    up.add_argument(
        "--byte-order",
        choices=("little", "big"),
        help="override the controller's (FS100 big, others little)",
    )
    up.add_argument(
        "--skip",
        action="append",
        metavar="SERVICE",
        help="do not start this service here, e.g. interpolator/1 when group 1's interpolator "
        "runs on another host (repeatable); the cell is NOT_READY until it joins",
    )
    add_zenoh_arguments(up)
    up.set_defaults(run=launcher.up)

    fault.add_parser(commands)
    observe.add_parsers(commands)
    record.add_parser(commands)
    plot.add_parser(commands)
    bench.add_parser(commands)

    router = commands.add_parser(
        "router", help="a Zenoh router (a stand-in for zenohd where its image is not available)"
    )
    router.add_argument(
        "--listen",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="default tcp/127.0.0.1:7447",
    )
    router.add_argument("--connect", action="append", default=[], metavar="ENDPOINT")
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
    return parser


def main(argv: Sequence[str] | None = None) -> None:
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s motocell %(levelname)s %(message)s")
    sys.exit(args.run(args))


if __name__ == "__main__":
    main()
