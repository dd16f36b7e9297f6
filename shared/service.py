"""What every service process does the same way: arguments, logging, signals, its session."""

from __future__ import annotations

import argparse
import ctypes
import faulthandler
import importlib.metadata
import logging
import math
import os
import select
import signal
import socket
import sys
import threading
import time
import weakref
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from types import FrameType

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


class StopFlag:
    """A stop request that a signal handler may raise and any thread may wait for.

    Raising it takes no lock. ``threading.Event.set`` takes its Condition's lock, and a second
    signal arriving while the first handler is inside it runs the handler again on the same
    thread, which then waits forever for the lock it already holds (a launcher was seen hung
    that way). Here ``set`` only stores a bool and writes one byte to a non-blocking pipe;
    waiters sleep in ``poll`` on the read end, which stays readable once set.
    """

    def __init__(self) -> None:
        self._requested = False
        self._wake_read, self._wake_write = os.pipe()
        os.set_blocking(self._wake_read, False)
        os.set_blocking(self._wake_write, False)
        # Closed only once nothing can wait on it any more, so no waiter ever polls a closed
        # (or reused) descriptor.
        weakref.finalize(self, _close_pipe, self._wake_read, self._wake_write)

    def set(self) -> None:
        if not self._requested:
            self._requested = True
            os.write(self._wake_write, b"\0")

    def is_set(self) -> bool:
        return self._requested

    def wait(self, timeout: float | None = None) -> bool:
        """True once set; False when ``timeout`` seconds passed first (None: no limit)."""
        if not self._requested:
            poller = select.poll()  # one per call: a poll object refuses concurrent waiters
            poller.register(self._wake_read, select.POLLIN)
            poller.poll(None if timeout is None else max(0, math.ceil(timeout * 1000)))
        return self._requested


def _close_pipe(*fds: int) -> None:
    for fd in fds:
        os.close(fd)


@contextmanager
def stop_on_signals(
    signals: Sequence[signal.Signals] = (signal.SIGINT, signal.SIGTERM),
) -> Iterator[StopFlag]:
    """A flag that SIGINT and SIGTERM set, however many arrive and however fast; the previous
    handlers come back on exit. Python sets signal handlers only in the main thread: elsewhere
    the flag is only set by whoever calls ``set``."""
    stop = StopFlag()
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return

    def handler(_signum: int, _frame: FrameType | None) -> None:
        stop.set()

    previous = {sig: signal.signal(sig, handler) for sig in signals}
    try:
        yield stop
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)


@dataclass
class ServiceContext:
    cell: Cell
    keys: CellKeys
    session: zenoh.Session
    stop: StopFlag


def die_with_launcher() -> None:
    """Ask the kernel for SIGTERM when the launcher dies; if it is already gone, stop now."""
    parent = os.environ.get(PARENT_PID_ENV)
    if parent is None or not sys.platform.startswith("linux"):
        return
    libc = ctypes.CDLL(None, use_errno=True)
    libc.prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
    if os.getppid() != int(parent):
        raise SystemExit("motocell: the launcher is gone")


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
    with stop_on_signals() as stop:
        # `kill -USR1 <pid>` prints every thread's stack: how to see where a service is stuck.
        faulthandler.register(signal.SIGUSR1, all_threads=True)
        die_with_launcher()
        with _service_session(service, instance, cell, args) as session:
            yield ServiceContext(cell, CellKeys(cell.name), session, stop)


@contextmanager
def _service_session(
    service: str, instance: str, cell: Cell, args: argparse.Namespace
) -> Iterator[zenoh.Session]:
    """The session, with the service's liveliness token and ``service_info`` queryable."""
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
        yield session
        token.undeclare()
        queryable.undeclare()
    finally:
        session.close()
