"""``motocell up``: a whole cell as child processes on this machine, in the foreground; and
``motocell router``, a standalone Zenoh router.

The launcher claims the cell's name in this user's registry of running cells (a second cell
of the same name is refused), writes fresh credentials for every identity of the cell (removed
with its registry entry when it stops), and runs a Zenoh router on loopback with the access
control derived from the key map; every service joins it as a client with its own
credentials. The first cell on a machine takes the well-known port 7447, a later one a free
port; observers find each through the registry.
``--open-bus`` runs without credentials or access control (and links a later cell's router to
7447, so one observer there sees every open cell). A child that dies is logged and restarted;
meanwhile the controller sees its liveliness token gone and the cell answers NOT_READY. A child
that cannot start as configured (EXIT_CONFIG) stops the cell instead, with the same status;
what can be checked before any child starts (the ports, the names ``--skip`` gives) is, so a
user's mistake costs one line.
Once the cell is whole and its ports listen, one INFO line says so (``ready_line``).

``core`` decides (children, ports, router endpoints, restarts, the warm parent's messages);
``loop`` supervises the children; ``processes``, ``warm`` (the services forked from the warm
parent, ``zygote``: docs/startup.md), ``router``, ``ports``, ``ready_line`` and
``realtime_line`` do the I/O; this module puts them together for the two commands.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import zenoh

from motocell.services.launcher.core.children import (
    EXECUTOR,
    UpOptions,
    child_specs,
    services_here,
)
from motocell.services.launcher.core.restarts import RestartPolicy
from motocell.services.launcher.core.tcp_ports import PORT_BASE_AUTO, port_base_problem, tcp_ports
from motocell.services.launcher.lifeline import LifelineError, check_lifeline, lifeline
from motocell.services.launcher.loop import supervise
from motocell.services.launcher.ports import PortError, check_router_endpoints, check_tcp_ports
from motocell.services.launcher.processes import Child, stop_children
from motocell.services.launcher.ready_line import ReadyNotice
from motocell.services.launcher.realtime_line import RealtimeNotice
from motocell.services.launcher.router import cell_router_endpoints, open_cell_router, serve_router
from motocell.services.launcher.warm import Starter, Zygote, become_subreaper, reap_strays
from motocell.services.launcher.warm_parent import StartedZygote
from motocell.shared import registry
from motocell.shared.bus.access import Identity, cell_identities
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.credentials import CredentialsError, write_passwords
from motocell.shared.bus.credentials import load as load_credentials
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.session import StoppedWaiting, open_session
from motocell.shared.config import EXIT_CONFIG, PORT_COUNT, Cell, ConfigError, load_cell
from motocell.shared.ports import free_port_block
from motocell.shared.realtime import enter_service_priority, leave_service_priority
from motocell.shared.registry import CellEntry, CellNameTakenError
from motocell.shared.ros2.extra import missing_ros2
from motocell.shared.service import StopFlag, stop_on_signals
from motocell.shared.service_names import (
    ROS2_FACE,
    WARM_SERVICES,
    ServiceName,
    UnknownServiceError,
    cell_services,
)

log = logging.getLogger("motocell")


def run(args: argparse.Namespace) -> int:
    """Run the cell until SIGINT or SIGTERM; the exit status (EXIT_CONFIG: it cannot run as
    configured, one line on stderr says why). Checked before anything starts: the names
    ``--skip`` gives, and that every port the cell will listen on is in range and free."""
    try:
        cell = load_cell(args.config, args.name)
        this_host = ThisHost(cell, args)
        check_lifeline(args.lifeline, args.lifeline_scratch)
        # The warm parent, started as this process's first act (``warm_parent``), so before
        # it takes the services' priority, which the warm parent's imports must not run at.
        with (
            stop_on_signals() as stop,
            warm_starter(args.warm_parent, this_host.services, stop) as starter,
        ):
            # Before the router opens, so that its threads inherit it; then this thread, which
            # starts the services, leaves it, so that their imports do not run at it.
            realtime = enter_service_priority(log, quiet=True)
            with (
                lifeline(args.lifeline, args.lifeline_scratch, stop),
                _cell_bus(cell, args, this_host, stop) as bus,
            ):
                if realtime:
                    leave_service_priority()
                return run_children(
                    cell, args, this_host, bus, stop, starter=starter, realtime=realtime
                )
    except StoppedWaiting:
        return 0  # stopped before the router it joins came
    except (
        ConfigError,
        CellNameTakenError,
        ConnectionError,
        CredentialsError,
        UnknownServiceError,
        PortError,
        LifelineError,
    ) as exc:
        print(f"motocell up: {_hint(exc, args)}", file=sys.stderr)
        return EXIT_CONFIG


class ThisHost:
    """What this launcher runs of the cell, and where its TCP ports are; PortError or
    UnknownServiceError for what cannot be."""

    def __init__(self, cell: Cell, args: argparse.Namespace) -> None:
        self.services = services_here(cell, args.skip or ())
        if ServiceName(ROS2_FACE, "0") in self.services:
            missing = missing_ros2()
            if missing is not None:
                raise ConfigError(
                    f"the cell file asks for the ROS 2 face ([ros2]), but {missing} "
                    f"(or --skip {ROS2_FACE} to run the cell without it)"
                )
        self.host: str = args.host or cell.host
        self.port_base = self._port_base(args.port_base, cell)
        self.served = cell.listening_at(self.host, self.port_base)
        """The cell as this host serves it: where its TCP ports are."""
        self.ports = tcp_ports(self.served, self.services)

    def _port_base(self, given: str | None, cell: Cell) -> int:
        if given is None:
            return cell.port_base
        problem = port_base_problem(given)
        if problem is not None:
            raise PortError(problem)
        if given == PORT_BASE_AUTO:
            return free_port_block(PORT_COUNT, self.host)
        return int(given)

    def check_ports(self) -> None:
        """PortError unless every TCP port this launcher's services need is free."""
        check_tcp_ports(self.host, self.ports)

    def describe(self) -> str:
        at = self.served
        return f"motion {at.host}:{at.motion_port}, state {at.state_port}, I/O {at.io_port}"


def _hint(exc: Exception, args: argparse.Namespace) -> str:
    if isinstance(exc, CellNameTakenError):
        how = "stop it" + (", or start this one with another --name" if not args.name else "")
        return f"{exc}; {how} (the name comes from {'--name' if args.name else 'the cell file'})"
    return str(exc)


@dataclass(frozen=True)
class CellBus:
    endpoints: list[str]
    """Where its services connect: its router, or every router it was told to join."""
    credentials: Path | None
    session: zenoh.Session
    """The launcher's own: its router, or an observer's session on the router it joined."""
    new: bool
    """Its own router, opened just now, secured with passwords written for this start."""


def _config_reference(config: str | None) -> str:
    """The cell file as another process finds it from anywhere (``CellEntry.config``)."""
    if config is None:
        return ""
    path = Path(config)
    return str(path.resolve()) if path.is_file() else config


@contextmanager
def _cell_bus(
    cell: Cell, args: argparse.Namespace, this_host: ThisHost, stop: StopFlag
) -> Iterator[CellBus]:
    """Claim the cell's name on this machine, check its ports, then its bus: its own router
    (secured unless --open-bus) or, with --zenoh-connect, a router that already runs."""
    secured = not args.open_bus
    if args.zenoh_connect:
        listen, connect = list(args.zenoh_connect), list[str]()
        credentials = Path(args.credentials) if args.credentials else None
    else:
        tcp_ports = [tcp.port for tcp in this_host.ports]
        listen, connect = cell_router_endpoints(
            args.zenoh_listen, secured=secured, tcp_ports=tcp_ports
        )
        credentials = registry.credentials_dir(cell.name) if secured else None
    entry = CellEntry(
        name=cell.name,
        pid=os.getpid(),
        host=this_host.host,
        port_base=this_host.port_base,
        zenoh_endpoint=listen[0],
        credentials=str(credentials or ""),
        config=_config_reference(args.config),
    )
    # The name first: a second start of a running cell is told that, not that its ports
    # are taken.
    registry.register(entry)
    try:
        this_host.check_ports()
        if args.zenoh_connect:
            session, new = _join(cell, listen, credentials, stop), False
        else:
            check_router_endpoints(listen)
            if credentials is not None:
                write_passwords(
                    credentials,
                    cell.name,
                    cell_identities(len(cell.groups), face=cell.ros2 is not None),
                )
            session, new = open_cell_router(cell, listen, connect, credentials), secured
        try:
            yield CellBus(listen, credentials, session, new)
        finally:
            session.close()
    finally:
        registry.unregister(cell.name, os.getpid())


def _join(
    cell: Cell, endpoints: list[str], credentials: Path | None, stop: StopFlag
) -> zenoh.Session:
    """An observer's session on a router that runs already (or is starting)."""
    observer = None
    if credentials is not None:
        observer = load_credentials(credentials, cell.name, Identity(Role.OBSERVER))
    return open_session("client", endpoints, credentials=observer, stop=stop.wait)


def run_children(
    cell: Cell,
    args: argparse.Namespace,
    this_host: ThisHost,
    bus: CellBus,
    stop: StopFlag,
    *,
    starter: Starter,
    realtime: bool,
) -> int:
    """``starter``: how a service's command line becomes a process (``warm_starter``);
    ``realtime``: whether this launcher got the services' priority (and so its children)."""
    options = UpOptions(
        config=args.config,
        name=args.name,
        credentials=str(bus.credentials) if bus.credentials else None,
        host=args.host,
        port_base=None if args.port_base is None else this_host.port_base,
        byte_order=args.byte_order,
        new_bus=bus.new,
    )
    specs = child_specs(this_host.services, options, bus.endpoints, [sys.executable, "-m"])
    children = [Child(spec, starter) for spec in specs]
    skipped = set(cell_services(cell)) - {spec.service for spec in specs}
    awaited = sorted(str(name) for name in skipped if name.service != ROS2_FACE)
    if awaited:
        log.info(
            "cell %s: %s not started here; the cell is ready once they join",
            cell.name,
            ", ".join(awaited),
        )
    if len(awaited) < len(skipped):
        log.info("cell %s: its ROS 2 face not started here; the cell moves without it", cell.name)
    keys = CellKeys(cell.name)
    security = "secured" if bus.credentials else "open bus"
    if not bus.credentials:
        log.warning(OPEN_BUS_WARNING, cell.name)
    ready = ReadyNotice(
        bus.session,
        keys,
        this_host.host,
        this_host.ports,
        f"cell {cell.name} ready: {this_host.describe()}; Zenoh {bus.endpoints[0]} ({security})",
    )
    notice = RealtimeNotice(
        bus.session,
        keys,
        lambda: _pid(children, EXECUTOR),
        services_realtime=realtime,
        executor_here=any(child.name == EXECUTOR for child in children),
    )
    try:
        status = supervise(
            children,
            RestartPolicy(),
            stop,
            lambda: _look(ready, notice),
            reap=lambda: _reap_strays(children, starter),
            started=starter.retire,
        )
    finally:
        ready.close()
        notice.close()
        stop_children(children)
        _reap_strays(children, starter)
        log.info("cell %s stopped", cell.name)
    return status


def _reap_strays(children: list[Child], starter: Starter) -> None:
    """Reap what the launcher adopted as a subreaper and no child is (``warm.reap_strays``)."""
    known = {child.process.pid for child in children if child.process is not None}
    reap_strays(known | starter.pids())


@contextmanager
def warm_starter(
    started: StartedZygote | None, services: list[ServiceName], stop: StopFlag
) -> Iterator[Starter]:
    """Forks of the warm parent ``started`` for the services it holds, unless there is none
    (``--cold``), this host runs none of them, or this system cannot make the launcher the
    forks' parent (docs/startup.md); the warm parent ends with the block, or at once where it
    is not used."""
    warm = started is not None and any(name.service in WARM_SERVICES for name in services)
    if started is not None and warm and become_subreaper():
        starter = Starter(Zygote(started, stop))
    else:
        if started is not None:
            started.close()
        starter = Starter(None)
    try:
        yield starter
    finally:
        starter.close()


OPEN_BUS_WARNING = (
    "cell %s runs on an open bus: anyone who reaches its Zenoh router can move the robot "
    "(drop --open-bus unless this network is trusted; docs/security.md)"
)

LOOK_S = 0.05
"""How often the launcher looks whether the cell is ready, until it has said so."""


def _look(ready: ReadyNotice, realtime: RealtimeNotice) -> float | None:
    """Look for the ready line and the executor's real-time report; when to look again (None:
    both are settled, nothing more to look for)."""
    if ready.check() and realtime.check():
        return None
    return time.monotonic() + LOOK_S


def _pid(children: list[Child], name: str) -> int | None:
    for child in children:
        if child.name == name and child.process is not None:
            return child.process.pid
    return None


def router(args: argparse.Namespace) -> int:
    """A Zenoh router in this process until SIGINT or SIGTERM."""
    try:
        check_lifeline(args.lifeline, ())
        with stop_on_signals() as stop, lifeline(args.lifeline, (), stop):
            enter_service_priority(log)  # every stream of the cells it serves goes through it
            serve_router(args.listen, args.connect, stop, args.config)
    except (ConnectionError, LifelineError) as exc:
        print(f"motocell router: {exc}", file=sys.stderr)
        return EXIT_CONFIG
    return 0
