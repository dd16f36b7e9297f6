"""What every service process does the same way: arguments, logging, signals, its session."""

from __future__ import annotations

import argparse
import ctypes
import faulthandler
import importlib.metadata
import logging
import os
import signal
import socket
import sys
import threading
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass

import zenoh

from shared.bus.keys import CellKeys
from shared.bus.schemas import ServiceInfo, encode
from shared.bus.session import open_session
from shared.config import Cell, ConfigError, load_cell

PARENT_PID_ENV = "MOTOCELL_PARENT_PID"
"""Set by ``motocell up`` for its children: they stop when that process goes away."""
PR_SET_PDEATHSIG = 1

REQUIRED_SERVICES = ("controller", "executor", "broadcaster", "gateway")
"""Services a cell needs besides one interpolator per group; see ``required_alive_keys``."""


def required_alive_keys(cell: Cell) -> list[str]:
    keys = CellKeys(cell.name)
    names = [keys.alive(service, "0") for service in REQUIRED_SERVICES]
    names += [keys.alive("interpolator", str(group.index)) for group in cell.groups]
    return names


def version() -> str:
    try:
        return importlib.metadata.version("motocell")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


def argument_parser(service: str, description: str) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog=f"motocell-{service}", description=description)
    parser.add_argument("--config", help="cell TOML file (default: one 6-axis arm, YRC1000)")
    add_zenoh_arguments(parser)
    parser.add_argument("--log-level", default=os.environ.get("MOTOCELL_LOG", "INFO"))
    return parser


def add_zenoh_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--zenoh-mode", choices=("peer", "client"), help="default: the cell file's, else peer"
    )
    parser.add_argument(
        "--zenoh-connect",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="endpoint to connect to, e.g. tcp/127.0.0.1:7447 (repeatable)",
    )
    parser.add_argument(
        "--zenoh-listen",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="endpoint to listen on (default for peers: tcp/127.0.0.1:0)",
    )


def setup_logging(service: str, level: str) -> None:
    logging.basicConfig(
        level=level.upper(),
        format=f"%(asctime)s {service}[%(process)d] %(levelname)s %(message)s",
    )


@dataclass
class ServiceContext:
    cell: Cell
    keys: CellKeys
    session: zenoh.Session
    stop: threading.Event


def die_with_launcher() -> None:
    """Ask the kernel for SIGTERM when the launcher dies; if it is already gone, stop now."""
    parent = os.environ.get(PARENT_PID_ENV)
    if parent is None or not sys.platform.startswith("linux"):
        return
    libc = ctypes.CDLL(None, use_errno=True)
    libc.prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
    if os.getppid() != int(parent):
        raise SystemExit("motocell: the launcher is gone")


def stop_on_signals() -> threading.Event:
    stop = threading.Event()

    def handler(signum: int, _frame: object) -> None:
        stop.set()

    signal.signal(signal.SIGTERM, handler)
    signal.signal(signal.SIGINT, handler)
    return stop


@contextmanager
def running_service(
    service: str, instance: str, args: argparse.Namespace
) -> Iterator[ServiceContext]:
    """Load the cell, open the session, declare the liveliness token; undo all on exit."""
    setup_logging(service if instance == "0" else f"{service}/{instance}", args.log_level)
    try:
        cell = load_cell(args.config)
    except ConfigError as exc:
        raise SystemExit(f"motocell-{service}: {exc}") from exc
    stop = stop_on_signals()
    # `kill -USR1 <pid>` prints every thread's stack: how to see where a service is stuck.
    faulthandler.register(signal.SIGUSR1, all_threads=True)
    die_with_launcher()
    mode = args.zenoh_mode or cell.zenoh.mode
    connect: Sequence[str] = args.zenoh_connect or cell.zenoh.connect
    listen: Sequence[str] | None = args.zenoh_listen or (
        None if mode == "client" else cell.zenoh.listen
    )
    session = open_session(mode, connect, listen)
    keys = CellKeys(cell.name)
    info = ServiceInfo(
        cell=cell.name,
        service=service,
        instance=instance,
        host=socket.gethostname(),
        pid=os.getpid(),
        started_unix_ns=time.time_ns(),
        version=version(),
    )

    def describe(query: zenoh.Query) -> None:
        # Under its own key, not the query's: one wildcard query gets every service's reply,
        # and replies on one key would be consolidated into one.
        query.reply(keys.service_info(service, instance), encode(info))
        query.drop()

    try:
        queryable = session.declare_queryable(keys.service_info(service, instance), describe)
        token = session.liveliness().declare_token(keys.alive(service, instance))
        logging.getLogger(service).info("up: cell %s (%s mode)", cell.name, mode)
        yield ServiceContext(cell, keys, session, stop)
        token.undeclare()
        queryable.undeclare()
    finally:
        session.close()
