"""``python -m services.launcher`` (``motocell up``): a whole cell as child processes on this
machine, in the foreground; and ``motocell router``, a standalone Zenoh router.

The launcher runs a Zenoh router on loopback that every service connects to (multicast
scouting stays off). The first cell on a machine takes the well-known port 7447, so observers
find it with no arguments; a later cell runs its router on a free port and links it to 7447,
so one observer sees every cell. A child that dies is logged and restarted; meanwhile the
controller sees its liveliness token gone and the cell answers NOT_READY.

``core`` decides (children, router endpoints, restarts); ``children`` and ``router`` do the
I/O; this module wires them. ``tools.cli`` builds its ``up`` and ``router`` subcommands from
``add_arguments`` and ``add_router_arguments`` here.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence

from services.launcher.children import Child, stop_children, supervise
from services.launcher.core import (
    WELL_KNOWN_ENDPOINT,
    RestartPolicy,
    UnknownServiceError,
    UpOptions,
    child_specs,
)
from services.launcher.router import open_cell_router, serve_router
from shared.config import Cell, ConfigError, load_cell
from shared.service import StopFlag, add_zenoh_arguments, stop_on_signals

log = logging.getLogger("motocell")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``motocell up`` and ``python -m services.launcher``."""
    parser.add_argument("--config", help="cell TOML file (default: one 6-axis arm on a YRC1000)")
    parser.add_argument("--host", help="address the TCP ports listen on (default 127.0.0.1)")
    parser.add_argument(
        "--port-base", type=int, help="motion port (default 50240); state +1, I/O +2"
    )
    parser.add_argument(
        "--byte-order",
        choices=("little", "big"),
        help="override the controller's (FS100 big, others little)",
    )
    parser.add_argument(
        "--skip",
        action="append",
        metavar="SERVICE",
        help="do not start this service here, e.g. interpolator/1 when group 1's interpolator "
        "runs on another host (repeatable); the cell is NOT_READY until it joins",
    )
    add_zenoh_arguments(parser)


def add_router_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``motocell router``."""
    parser.add_argument(
        "--listen",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help=f"default {WELL_KNOWN_ENDPOINT}",
    )
    parser.add_argument("--connect", action="append", default=[], metavar="ENDPOINT")


def up_options(args: argparse.Namespace) -> UpOptions:
    return UpOptions(
        config=args.config,
        zenoh_mode=args.zenoh_mode,
        host=args.host,
        port_base=args.port_base,
        byte_order=args.byte_order,
        skip=tuple(args.skip or ()),
    )


def run(args: argparse.Namespace) -> int:
    """Run the cell until SIGINT or SIGTERM; the exit status (2: bad arguments)."""
    try:
        cell = load_cell(args.config)
    except ConfigError as exc:
        print(f"motocell up: {exc}", file=sys.stderr)
        return 2
    with stop_on_signals() as stop:
        if args.zenoh_connect:
            return run_children(cell, args, args.zenoh_connect[0], stop)
        hub, endpoint = open_cell_router(args.zenoh_listen)
        try:
            return run_children(cell, args, endpoint, stop)
        finally:
            hub.close()


def run_children(cell: Cell, args: argparse.Namespace, endpoint: str, stop: StopFlag) -> int:
    try:
        specs = child_specs(cell, up_options(args), endpoint, [sys.executable, "-m"])
    except UnknownServiceError as exc:
        print(f"motocell up: {exc}", file=sys.stderr)
        return 2
    port = args.port_base or cell.port_base
    log.info(
        "cell %s: %d group(s), ports %s:%d-%d, Zenoh at %s",
        *(cell.name, len(cell.groups), args.host or cell.host, port, port + 2, endpoint),
    )
    children = [Child(spec) for spec in specs]
    try:
        supervise(children, RestartPolicy(), stop)
    finally:
        stop_children(children)
        log.info("cell %s stopped", cell.name)
    return 0


def router(args: argparse.Namespace) -> int:
    """A Zenoh router in this process until SIGINT or SIGTERM."""
    with stop_on_signals() as stop:
        serve_router(args.listen, args.connect, stop)
    return 0


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="motocell-launcher", description="Run a whole cell.")
    add_arguments(parser)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s motocell %(levelname)s %(message)s")
    sys.exit(run(args))


if __name__ == "__main__":
    main()
