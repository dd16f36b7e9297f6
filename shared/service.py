"""What every service process does the same way: arguments, logging, signals, its session."""

from __future__ import annotations

import argparse
import ctypes
import faulthandler
import gc
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
from collections.abc import Collection, Iterator, Sequence
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass
from pathlib import Path
from types import FrameType

import msgspec
import zenoh

from motocell.shared.bus.access import Identity
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.claim import ClaimError, claim_name, watch_claims
from motocell.shared.bus.credentials import CredentialsError
from motocell.shared.bus.credentials import load as load_credentials
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.runtime import zenoh_runtime
from motocell.shared.bus.schemas import Listening, ServiceInfo, encode
from motocell.shared.bus.session import ENCODING, StoppedWaiting, open_session
from motocell.shared.config import EXIT_CONFIG, Cell, ConfigError, load_cell
from motocell.shared.ports import port_base_argument
from motocell.shared.realtime import enter_service_priority
from motocell.shared.service_names import (
    ROS2_FACE,
    ServiceName,
    UnknownServiceError,
    cell_services,
    parse_service,
)
from motocell.shared.signals import STOP_SIGNALS

PARENT_PID_ENV = "MOTOCELL_PARENT_PID"
"""Set by ``motocell up`` for its children: they stop when that process goes away."""
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


def version() -> str:
    # Imported only where needed: importlib.metadata brings the email package, 10-20 ms that
    # `motocell up` would spend before it starts a single service.
    import importlib.metadata  # noqa: PLC0415

    try:
        return importlib.metadata.version("motocell")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


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


class Description:
    """What the service's ``service/<service>/<instance>`` queryable answers (``motocell ps``):
    made at start, and completed with the TCP ports the service serves once it listens."""

    def __init__(self, key: str, info: ServiceInfo) -> None:
        self._key = key
        self.info = info
        self._reply = encode(info)

    def listening(self, port_name: str, address: tuple[str, int]) -> None:
        """The service serves ``port_name`` at ``address`` (its socket's ``getsockname()``)."""
        port = Listening(port_name, address[0], address[1])
        self.info = msgspec.structs.replace(self.info, listening=[*self.info.listening, port])
        self._reply = encode(self.info)

    def answer(self, query: zenoh.Query) -> None:
        # Under its own key, not the query's: one wildcard query gets every service's reply,
        # and replies on one key would be consolidated into one. Encoded in advance: this runs
        # on a Zenoh thread.
        query.reply(self._key, self._reply, encoding=ENCODING)
        query.drop()


class AliveToken:
    """The service's liveliness token, declared by ``announce`` once the service listens.

    Present means listening: the controller counts a service present (its status's
    ``missing_services``), and the launcher the cell ready, from this token. Declared before
    the service's subscriptions, a change published the moment it appeared (the controller's
    status on the cell becoming whole) could reach the router before the subscription did and
    never reach the service, which would then go on the old value until the next heartbeat: a
    second on a resting cell, on the way to motion-ready (figure 9)."""

    def __init__(self, session: zenoh.Session, key: str, log: logging.Logger, up: str) -> None:
        self._session = session
        self._key = key
        self._log = log
        self._up = up
        """What the service's log says once it is announced."""
        self._token: zenoh.LivelinessToken | None = None

    def announce(self) -> None:
        """Call once every subscription and queryable the service needs is declared."""
        if self._token is None:
            self._token = self._session.liveliness().declare_token(self._key)
            self._log.info("%s", self._up)

    def withdraw(self) -> None:
        if self._token is not None:
            self._token.undeclare()
            self._token = None


@dataclass
class ServiceContext:
    cell: Cell
    keys: CellKeys
    session: zenoh.Session
    stop: StopFlag
    description: Description
    alive: AliveToken


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
    """Load the cell, open the session, claim the name, declare the liveliness token; undo
    all on exit. A start that cannot work as configured (bad cell file, no such service in
    the cell, credentials refused, no router, the name taken, a StartError from the body)
    prints one line and exits with EXIT_CONFIG, which the launcher takes as "do not
    restart". What can be checked without Zenoh is checked before joining it."""
    name = ServiceName(service, instance)
    setup_logging(str(name), args.log_level)
    with stop_on_signals() as stop, ExitStack() as joined:
        # `kill -USR1 <pid>` prints every thread's stack: how to see where a service is stuck.
        faulthandler.register(signal.SIGUSR1, all_threads=True)
        die_with_launcher()
        # Before the session opens, whose threads inherit it; `motocell up` says a refusal once.
        enter_service_priority(logging.getLogger(service), quiet=PARENT_PID_ENV in os.environ)
        try:
            given = vars(args)
            cell = load_cell(args.config, args.name).listening_at(
                given.get("host"), given.get("port_base"), given.get("byte_order")
            )
            parse_service(str(name), cell)  # an interpolator of a group the cell lacks
            session, description, alive = joined.enter_context(
                _service_session(service, instance, cell, args, stop)
            )
        except StoppedWaiting:
            raise SystemExit(0) from None  # stopped before the router came
        except (
            ConfigError,
            UnknownServiceError,
            CredentialsError,
            ConnectionError,
            ClaimError,
        ) as exc:
            print(f"motocell {name}: {exc}", file=sys.stderr)
            raise SystemExit(EXIT_CONFIG) from None
        # Why it cannot go on as configured: another process took its name, or a StartError.
        failed: list[str] = []

        def give_way(why: str) -> None:
            failed.append(f"{why}; this one stops")
            stop.set()

        keys = CellKeys(cell.name)
        joined.callback(watch_claims(session, keys, service, instance, give_way).undeclare)
        freeze_what_lives_forever()
        try:
            yield ServiceContext(cell, keys, session, stop, description, alive)
        except StartError as exc:
            failed.append(str(exc))
    if failed:
        print(f"motocell {name}: {failed[0]}", file=sys.stderr)
        raise SystemExit(EXIT_CONFIG)


def freeze_what_lives_forever() -> None:
    """Take everything made so far (modules, classes, the session: about 30 000 objects in the
    gateway) out of the garbage collector's sight: they live as long as the process, and each
    full collection would walk them all, a pause of about 8 ms for whichever thread allocated
    next (docs/realtime.md, Garbage collection).

    No collection first: it would cost those 8 ms of every service's start-up, on the way to
    motion-ready, to free a few dozen objects of import-time garbage."""
    gc.freeze()


@contextmanager
def _service_session(
    service: str, instance: str, cell: Cell, args: argparse.Namespace, stop: StopFlag
) -> Iterator[tuple[zenoh.Session, Description, AliveToken]]:
    """The session, with the service's ``service_info`` queryable and its liveliness token
    (declared when the service announces itself)."""
    connect: Sequence[str] = args.zenoh_connect or cell.zenoh.connect
    credentials = None
    if args.credentials:
        identity = Identity(Role(service), instance)
        credentials = load_credentials(Path(args.credentials), cell.name, identity)
    with zenoh_runtime():
        session = open_session("client", connect, credentials=credentials, stop=stop.wait)
    keys = CellKeys(cell.name)
    # Made here, not when first asked: looking up the version on a Zenoh thread would hold the
    # GIL for milliseconds, long enough to delay the executor's clock thread by a period.
    info = ServiceInfo(
        cell=cell.name,
        service=service,
        instance=instance,
        host=socket.gethostname(),
        pid=os.getpid(),
        started_unix_ns=time.time_ns(),
        version=version(),
    )
    description = Description(keys.service_info(service, instance), info)
    try:
        claim = claim_name(session, keys, service, instance)
        queryable = session.declare_queryable(
            keys.service_info(service, instance), description.answer
        )
        alive = AliveToken(
            session,
            keys.alive(service, instance),
            logging.getLogger(service),
            f"up: cell {cell.name} at {', '.join(connect)}",
        )
        yield session, description, alive
        alive.withdraw()
        queryable.undeclare()
        claim.undeclare()
    finally:
        session.close()
