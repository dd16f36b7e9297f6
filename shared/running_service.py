"""A service's life on the bus, from its start to its end: its session, its claim on its name,
its description and its liveliness token (``running_service``).

Apart from ``shared.service`` (arguments, signals, what the launcher uses too) because it does
at import what every service would otherwise do after it is forked: read the robot models'
catalogue (``config.load_catalogue``, read once per process), which its cell file's loading
needs, and make msgspec's decoders of a cell file's tables (``parse_cell``). The launcher's
warm parent imports this module with the services' own, so each fork of it starts with both in
the pages it shares with the others instead of a copy of its own (docs/startup.md, "Where a
cell's memory is").
"""

from __future__ import annotations

import argparse
import faulthandler
import gc
import logging
import os
import signal
import socket
import sys
import time
from collections.abc import Iterator, Sequence
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass
from pathlib import Path

import msgspec
import zenoh

from motocell import __version__
from motocell.shared.bus.access import Identity
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.claim import ClaimError, claim_name, watch_claims
from motocell.shared.bus.credentials import CredentialsError
from motocell.shared.bus.credentials import load as load_credentials
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.runtime import zenoh_runtime
from motocell.shared.bus.schemas import Listening, ServiceInfo, encode
from motocell.shared.bus.session import ENCODING, StoppedWaiting, open_session
from motocell.shared.config import (
    EXIT_CONFIG,
    Cell,
    ConfigError,
    load_catalogue,
    load_cell,
    parse_cell,
)
from motocell.shared.launcher_names import PARENT_PID_ENV
from motocell.shared.realtime import enter_service_priority
from motocell.shared.service import (
    StartError,
    StopFlag,
    die_with_launcher,
    setup_logging,
    stop_on_signals,
)
from motocell.shared.service_names import ServiceName, UnknownServiceError, parse_service

load_catalogue()
# The default cell's tables, decoded so that msgspec's decoders of a cell file are made here,
# once for every fork, not in each (0.6 ms of a service's start).
parse_cell({})


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


def claims_at_once(args: argparse.Namespace) -> bool:
    """Whether this start's claim skips the settles: ``--new-bus``, in a launcher's child only
    (docs/topology.md, rule 6); the same line typed into a shell settles."""
    return bool(args.new_bus) and PARENT_PID_ENV in os.environ


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
    # Made and encoded here, not when first asked: queries are answered on a Zenoh thread, where
    # no service logic runs (docs/conventions.md, The bus).
    info = ServiceInfo(
        cell=cell.name,
        service=service,
        instance=instance,
        host=socket.gethostname(),
        pid=os.getpid(),
        started_unix_ns=time.time_ns(),
        version=__version__,
    )
    description = Description(keys.service_info(service, instance), info)
    try:
        if stop.is_set():  # a start its launcher's death stopped claims nothing
            raise StoppedWaiting
        claim = claim_name(session, keys, service, instance, sole=claims_at_once(args))
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
