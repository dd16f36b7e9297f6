"""What every service process does the same way: arguments, logging, signals, its death with
the launcher. Its session and its life on the bus are ``shared.running_service``'s."""

from __future__ import annotations

import argparse
import ctypes
import logging
import math
import os
import select
import signal
import socket
import sys
import threading
import weakref
from collections.abc import Collection, Iterator
from contextlib import contextmanager
from types import FrameType

from motocell.shared.bus.keys import CellKeys
from motocell.shared.config import Cell
from motocell.shared.launcher_names import PARENT_PID_ENV
from motocell.shared.ports import port_base_argument
from motocell.shared.service_names import ROS2_FACE, cell_services
from motocell.shared.signals import STOP_SIGNALS

PR_SET_PDEATHSIG = 1


def required_alive_keys(cell: Cell) -> list[str]:
    """The liveliness keys of the services the cell cannot move without. Not its ROS 2 face:
    a Simple Message client does not wait for it, as a MotoROS1 client never waited for
    MotoROS2."""
    keys = CellKeys(cell.name)
    return [
        keys.alive(name.service, name.instance)
        for name in cell_services(cell)
        if name.service != ROS2_FACE
    ]


class StartError(Exception):
    """The service cannot run as configured, found once it runs (a port it must serve is
    taken): ``running_service`` prints the message as one line and exits with EXIT_CONFIG."""


def listen(host: str, port: int) -> socket.socket:
    """A listening TCP socket for one of the cell's Simple Message ports; a port that cannot be
    served is a StartError (not restarted by the launcher: it would fail the same way)."""
    server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        server.bind((host, port))
    except (OSError, OverflowError) as exc:
        server.close()
        reason = exc.strerror if isinstance(exc, OSError) else "a port is 1 to 65535"
        raise StartError(f"cannot listen on {host}:{port}: {reason}") from exc
    server.listen(socket.SOMAXCONN)
    return server


def argument_parser(service: str, description: str) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog=f"motocell service {service}", description=description, allow_abbrev=False
    )
    add_cell_arguments(parser)
    add_bus_arguments(parser)
    parser.add_argument("--log-level", default=os.environ.get("MOTOCELL_LOG", "INFO"))
    return parser


def add_listening_arguments(parser: argparse.ArgumentParser) -> None:
    """For a service with TCP ports: where they are, instead of the cell file's
    (``running_service`` applies them to ``ServiceContext.cell``)."""
    parser.add_argument("--host", help="address to listen on (default: the cell file's)")
    parser.add_argument(
        "--port-base",
        type=port_base_argument,
        help="the motion port; the state and I/O ports follow it (default: the cell file's)",
    )
    parser.add_argument("--byte-order", choices=("little", "big"))


def add_cell_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", help="cell TOML file (default: one 6-axis arm, YRC1000)")
    parser.add_argument("--name", help="the cell's name (default: the cell file's)")


def add_bus_arguments(parser: argparse.ArgumentParser) -> None:
    """How a service joins its cell's bus: always as a client of a router."""
    parser.add_argument(
        "--zenoh-connect",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="the cell's Zenoh router, e.g. tcp/127.0.0.1:7447 (repeatable; default: the "
        "cell file's [zenoh] connect)",
    )
    parser.add_argument(
        "--credentials",
        metavar="DIR",
        help="the cell's credentials directory (motocell credentials, or the one motocell up "
        "writes): join as this service's identity; without it the bus must be open",
    )
    # Given by `motocell up` to each service's first start on the secured router it has just
    # opened, where the claim need not settle (docs/topology.md, rule 6); honoured only in a
    # launcher's child, so a command line copied from `ps` into a shell settles as it should.
    parser.add_argument("--new-bus", action="store_true", help=argparse.SUPPRESS)


def setup_logging(service: str, level: str) -> None:
    logging.basicConfig(
        level=level.upper(),
        format=f"%(asctime)s {service}[%(process)d] %(levelname)s %(message)s",
    )


class StopFlag:
    """A stop request that a signal handler may raise and any thread may wait for.

    Raising it takes no lock. ``threading.Event.set`` takes its Condition's lock, and a second
    signal arriving while the first handler is inside it runs the handler again on the same
    thread, which then waits forever for the lock it already holds. Here ``set`` only stores a
    bool and writes one byte to a non-blocking pipe; waiters sleep in ``poll`` on the read end,
    which stays readable once set.
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

    def fileno(self) -> int:
        """A descriptor that becomes readable once the flag is set, for ``poll``."""
        return self._wake_read

    @property
    def wakeup_fd(self) -> int:
        """The pipe's write end, for ``signal.set_wakeup_fd``: a byte written there wakes
        every waiter as ``set`` does (``stop_on_signals``)."""
        return self._wake_write

    def wait(self, timeout: float | None = None) -> bool:
        """True once set; False when ``timeout`` seconds passed first (None: no limit)."""
        if self._requested:
            return True
        poller = select.poll()  # one per call: a poll object refuses concurrent waiters
        poller.register(self._wake_read, select.POLLIN)
        woken = poller.poll(None if timeout is None else max(0, math.ceil(timeout * 1000)))
        # Readable before the flag is set: a stop signal's wakeup byte, its handler about to
        # run on the main thread.
        return self._requested or bool(woken)


def _close_pipe(*fds: int) -> None:
    for fd in fds:
        os.close(fd)


@contextmanager
def stop_on_signals(
    signals: Collection[signal.Signals] = STOP_SIGNALS,
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
    # A signal sent to the process may be taken by any thread that does not block it (one of
    # Zenoh's), and the handler then waits to run until the main thread wakes, which may sleep
    # in poll on this very flag: a launcher's SIGINT, or the SIGTERM a service gets when its
    # launcher dies, would wait for ever. Python writes to the wakeup descriptor from whichever
    # thread takes the signal, so the flag's own pipe wakes the main thread and every waiter.
    previous_wakeup = signal.set_wakeup_fd(stop.wakeup_fd, warn_on_full_buffer=False)
    # Whoever started this process may have blocked them (``motocell service``), so that one
    # arriving during start-up waits for this handler instead of interrupting the imports
    # with a traceback: it is delivered now.
    signal.pthread_sigmask(signal.SIG_UNBLOCK, signals)
    try:
        yield stop
    finally:
        signal.set_wakeup_fd(previous_wakeup)
        for sig, old in previous.items():
            signal.signal(sig, old)


def die_with_launcher() -> None:
    """Ask the kernel for SIGTERM when the launcher dies; if it is already gone, stop now."""
    parent = os.environ.get(PARENT_PID_ENV)
    if parent is None or not sys.platform.startswith("linux"):
        return
    libc = ctypes.CDLL(None, use_errno=True)
    libc.prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
    if os.getppid() != int(parent):
        raise SystemExit("motocell: the launcher is gone")
