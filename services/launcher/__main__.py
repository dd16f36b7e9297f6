"""``python -m services.launcher`` (``motocell up``): a whole cell as child processes on this
machine, in the foreground; and ``motocell router``, a standalone Zenoh router.

The launcher claims the cell's name in this user's registry of running cells (a second cell
of the same name is refused), writes fresh credentials for every identity of the cell, and runs
a Zenoh router on loopback with the access control derived from the key map; every service
joins it as a client with its own credentials. The first cell on a machine takes the
well-known port 7447, a later one a free port; observers find each through the registry.
``--open-bus`` runs without credentials or access control (and links a later cell's router to
7447, as before). A child that dies is logged and restarted; meanwhile the controller sees its
liveliness token gone and the cell answers NOT_READY. A child that cannot start as configured
(EXIT_CONFIG) stops the cell instead.

``core`` decides (children, router endpoints, restarts); ``children`` and ``router`` do the
I/O; this module wires them. ``tools.cli`` builds its ``up`` and ``router`` subcommands from
``add_arguments`` and ``add_router_arguments`` here.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import zenoh

from services.launcher.children import Child, stop_children, supervise
from services.launcher.core import (
    WELL_KNOWN_ENDPOINT,
    RestartPolicy,
    UnknownServiceError,
    UpOptions,
    child_specs,
)
from services.launcher.realtime import RealtimeNotice
from services.launcher.router import cell_router_endpoints, open_cell_router, serve_router
from shared import registry
from shared.bus.access import Identity, cell_identities
from shared.bus.catalog import Role
from shared.bus.credentials import CredentialsError, write_passwords
from shared.bus.credentials import load as load_credentials
from shared.bus.keys import CellKeys
from shared.bus.session import open_session
from shared.config import EXIT_CONFIG, Cell, ConfigError, load_cell
from shared.registry import CellEntry, CellNameTakenError
from shared.service import StopFlag, add_bus_arguments, add_cell_arguments, stop_on_signals

log = logging.getLogger("motocell")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``motocell up`` and ``python -m services.launcher``."""
    add_cell_arguments(parser)
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
    parser.add_argument(
        "--zenoh-listen",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help=f"where the cell's own router listens (default {WELL_KNOWN_ENDPOINT}, or a free "
        "port when that is taken)",
    )
    add_bus_arguments(parser)
    parser.add_argument(
        "--open-bus",
        action="store_true",
        help="no credentials and no access control: anyone who reaches the router can move "
        "the robot. Only for a trusted lab network (see docs/security.md)",
    )


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
    parser.add_argument(
        "--config",
        metavar="FILE",
        help="run from a Zenoh router config file instead, as `zenohd -c FILE` does (e.g. "
        "deploy/zenoh/router.json5); --listen/--connect are then ignored",
    )


def run(args: argparse.Namespace) -> int:
    """Run the cell until SIGINT or SIGTERM; the exit status (EXIT_CONFIG: it cannot run as
    configured, one line on stderr says why)."""
    try:
        cell = load_cell(args.config, args.name)
        with stop_on_signals() as stop, _cell_bus(cell, args) as bus:
            return run_children(cell, args, bus, stop)
    except (
        ConfigError,
        CellNameTakenError,
        ConnectionError,
        CredentialsError,
        UnknownServiceError,
    ) as exc:
        print(f"motocell up: {_hint(exc, args)}", file=sys.stderr)
        return EXIT_CONFIG


def _hint(exc: Exception, args: argparse.Namespace) -> str:
    if isinstance(exc, CellNameTakenError):
        how = "stop it" + (", or start this one with another --name" if not args.name else "")
        return f"{exc}; {how} (the name comes from {'--name' if args.name else 'the cell file'})"
    return str(exc)


@dataclass(frozen=True)
class CellBus:
    endpoint: str
    credentials: Path | None
    session: zenoh.Session
    """The launcher's own: its router, or an observer's session on the router it joined."""


@contextmanager
def _cell_bus(cell: Cell, args: argparse.Namespace) -> Iterator[CellBus]:
    """Claim the cell's name on this machine, then its bus: its own router (secured unless
    --open-bus) or, with --zenoh-connect, a router that already runs."""
    secured = not args.open_bus
    if args.zenoh_connect:
        listen, connect = list(args.zenoh_connect), list[str]()
        credentials = Path(args.credentials) if args.credentials else None
    else:
        listen, connect = cell_router_endpoints(args.zenoh_listen, secured=secured)
        credentials = registry.credentials_dir(cell.name) if secured else None
    entry = CellEntry(
        name=cell.name,
        pid=os.getpid(),
        host=args.host or cell.host,
        port_base=args.port_base or cell.port_base,
        zenoh_endpoint=listen[0],
        credentials=str(credentials or ""),
    )
    registry.register(entry)
    try:
        if args.zenoh_connect:
            observer = None
            if credentials is not None:
                observer = load_credentials(credentials, cell.name, Identity(Role.OBSERVER))
            session = open_session("client", listen, credentials=observer)
        else:
            if credentials is not None:
                write_passwords(credentials, cell.name, cell_identities(len(cell.groups)))
            session = open_cell_router(cell, listen, connect, credentials)
        try:
            yield CellBus(listen[0], credentials, session)
        finally:
            session.close()
    finally:
        registry.unregister(cell.name, os.getpid())


def run_children(cell: Cell, args: argparse.Namespace, bus: CellBus, stop: StopFlag) -> int:
    options = UpOptions(
        config=args.config,
        name=args.name,
        credentials=str(bus.credentials) if bus.credentials else None,
        host=args.host,
        port_base=args.port_base,
        byte_order=args.byte_order,
        skip=tuple(args.skip or ()),
    )
    specs = child_specs(cell, options, bus.endpoint, [sys.executable, "-m"])
    port = args.port_base or cell.port_base
    log.info(
        "cell %s: %d group(s), ports %s:%d-%d, Zenoh at %s (%s)",
        *(cell.name, len(cell.groups), args.host or cell.host, port, port + 2, bus.endpoint),
        "secured" if bus.credentials else "open bus",
    )
    children = [Child(spec) for spec in specs]
    notice = RealtimeNotice(bus.session, CellKeys(cell.name), lambda: _pid(children, "executor"))
    try:
        status = supervise(children, RestartPolicy(), stop, notice.check)
    finally:
        notice.close()
        stop_children(children)
        log.info("cell %s stopped", cell.name)
    return status


def _pid(children: list[Child], name: str) -> int | None:
    for child in children:
        if child.name == name and child.process is not None:
            return child.process.pid
    return None


def router(args: argparse.Namespace) -> int:
    """A Zenoh router in this process until SIGINT or SIGTERM."""
    try:
        with stop_on_signals() as stop:
            serve_router(args.listen, args.connect, stop, args.config)
    except ConnectionError as exc:
        print(f"motocell router: {exc}", file=sys.stderr)
        return EXIT_CONFIG
    return 0


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        prog="python -m services.launcher", description="Run a whole cell.", allow_abbrev=False
    )
    add_arguments(parser)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s motocell %(levelname)s %(message)s")
    sys.exit(run(args))


if __name__ == "__main__":
    main()
