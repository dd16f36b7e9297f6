"""Started cells for a test, whatever runs it: ``cell()`` starts one, ``cells()`` as many as a
test asks for; each stops, with every process of it proven gone, when its block ends, also on
a failure or Ctrl-C; and with the process that started it, however that process ends, leaving
no file behind (``running_cell.start_cell``). The pytest plugin (``motocell.testing.plugin``)
is these as fixtures.

A cell here is what ``testing.running_cell`` starts for the project's own tests:
free loopback ports, its own router on a free port, secured (every identity has a password),
its own registry of running cells; and a name of its own, so two cells of one test, or of two
test runs at once, are never confused.
"""

from __future__ import annotations

import dataclasses
import itertools
import os
import tempfile
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path
from typing import Any

import zenoh

from motocell.shared import faults
from motocell.shared.bus.catalog import Role
from motocell.shared.config import Cell, Ros2Face
from motocell.shared.protocol.constants import Result, describe_reply
from motocell.testing.cell_file import write_cell_file
from motocell.testing.cell_status import CellStatus, cell_status
from motocell.testing.following import FollowingError, following_errors
from motocell.testing.observer import CellObserver
from motocell.testing.report import Reported, Starts
from motocell.testing.running_cell import RunningCell, log_tail, running_cell

START_TIMEOUT_S = 60.0
"""For a cell to be whole: about a second on an idle machine, many times that on a loaded one;
a bound for a hang, not a speed. A start that fails (a port taken meanwhile) is tried once
more on new ports."""
STATE_TIMEOUT_S = 10.0
REST_TIMEOUT_S = 30.0
REPORT_TIMEOUT_S = 2.0
"""For a failed test's report to read the cell's state: a running cell's observer heard its
status and state long before, so only a cell that stopped answering waits this long."""
LOG_LINES = 20
"""Of the cell's log, in a failed test's report."""
START_FAULTS = (
    ("estop", "off"),
    ("hold", "off"),
    ("alarm", "clear"),
    ("error", "clear"),
    ("pfl", "off"),
    ("play", "play"),
    ("remote", "on"),
    ("servo", "off"),
)
"""The controller's switches as a cell starts with them, in ``fault``'s words: ``reset``."""

_numbers = itertools.count(1)


def unique_name() -> str:
    """``test-<pid>-<n>``: unique on this machine while this process runs."""
    return f"test-{os.getpid()}-{next(_numbers)}"


class FaultError(RuntimeError):
    """The controller refused the fault, or no controller answered."""


class CellUnderTest(Reported):
    """A started cell: where to reach it, and what a test asks of it without knowing Zenoh."""

    def __init__(self, running: RunningCell, session: zenoh.Session, log: Path) -> None:
        self.running = running
        """The harness's cell (``motocell.testing.running_cell``): its Simple Message clients
        (``motion()``, ``io()``, ``state()``), its processes, a Zenoh ``session()``."""
        self.bus = session
        """A Zenoh session on the cell's bus as its operator: it sees every key, and may
        inject faults. Closed when the cell stops."""
        self.config: Cell = dataclasses.replace(
            running.cell, host=running.host, port_base=running.port_base
        )
        """The cell as its services run it: groups, models, periods, byte order, ports."""
        self.log = log
        """The file its launcher and services write their log to (``MOTOCELL_TEST_LOG``: at
        WARNING unless set), removed with the cell."""
        self.stopped = False
        """Its ``cell()`` block ended: nothing of it runs."""
        self._observer = CellObserver(session, running.keys)
        self._faults_seen = 0
        """The controller status that shows the last fault injected (its reply's
        ``status_seq``): what ``status()`` waits for."""

    @property
    def name(self) -> str:
        return self.config.name

    @property
    def host(self) -> str:
        return self.config.host

    @property
    def motion_port(self) -> int:
        return self.config.motion_port

    @property
    def state_port(self) -> int:
        return self.config.state_port

    @property
    def io_port(self) -> int:
        return self.config.io_port

    @property
    def byte_order(self) -> str:
        """``little``, or ``big`` (an FS100, or asked for)."""
        return self.config.byte_order

    @property
    def ros2(self) -> Ros2Face | None:
        """The ROS 2 face's settings; None for a cell without ``[ros2]``. What a ROS 2 client
        needs to reach it: ``ros_domain_id`` (``rclpy.init(domain_id=...)``) and
        ``node_namespace``, under which its topics, services and action are; ``node_name`` is
        the face's node (``motoman_<cell name>`` unless the cell file names it)."""
        return self.config.ros2

    @property
    def zenoh_endpoint(self) -> str:
        """The cell's router: ``motocell watch --zenoh-connect ENDPOINT --credentials DIR``."""
        return self.running.zenoh_endpoint

    @property
    def credentials(self) -> Path:
        """The cell's credentials directory (a password per identity)."""
        directory = self.running.credentials
        assert directory is not None, "a cell started here runs its own, secured, router"
        return directory

    def positions(self, group: int = 0, timeout: float = STATE_TIMEOUT_S) -> tuple[float, ...]:
        """The group's joint positions (radians, metres for a linear axis; ROS order) in the
        newest state snapshot: the feedback, as JOINT_FEEDBACK carries it."""
        state = self._observer.state(timeout)
        return tuple(state.groups[group].positions[: self.config.groups[group].axes])

    def status(self, timeout: float = STATE_TIMEOUT_S) -> CellStatus:
        """The cell now: servo, PLAY or TEACH, REMOTE, E-stop, HOLD, alarms, error, whether
        motion is ready, which face holds trajectory mode, every group's positions; from the
        newest controller status, one that shows every fault this object injected, and the
        newest state snapshot. TimeoutError after ``timeout`` s without them."""
        controller = self._observer.controller(timeout, since_seq=self._faults_seen)
        holder = self._observer.holder(timeout)
        return cell_status(controller, holder, self._observer.state(timeout), self.config)

    def reset(self) -> None:
        """The controller's switches back to how a cell starts: E-stop, HOLD, PFL and servo
        off, alarms and error cleared, PLAY and REMOTE (``START_FAULTS``). The servo going off
        stops the INIT_ROS job, and so ends trajectory mode, as a real controller's does. Not
        the rest: the arm stays where it is, I/O, M-registers and tools keep their values."""
        for kind, setting in START_FAULTS:
            self.fault(kind, setting)

    def wait_at_rest(self, timeout: float = REST_TIMEOUT_S) -> None:
        """Until the executor says its clock rests: nothing queued, owed or settling, for a
        second. Call it once the motion's last point was accepted; it takes about a second
        after the robot stops (or, at rest already, until the executor says so again, once a
        second). TimeoutError after ``timeout`` s."""
        self._observer.wait_at_rest(timeout)

    def fault(self, kind: str, setting: str | int = "on", subcode: int | None = None) -> None:
        """What ``motocell fault KIND SETTING [SUBCODE]`` does: ``fault("estop")``,
        ``fault("hold", "off")``, ``fault("alarm", 4100, 2)``, ``fault("alarm", "clear")``.
        ValueError for a fault the command would refuse; FaultError when the controller
        refuses it or does not answer."""
        kind = kind.lower()
        if kind not in faults.KINDS:
            raise ValueError(f"fault {kind!r}: expected one of {', '.join(faults.KINDS)}")
        request = faults.request_for(kind, str(setting), subcode)
        reply = faults.inject(self.bus, self.name, kind, request)
        if reply is None:
            raise FaultError(f"fault {kind} {setting}: no controller of cell {self.name} answered")
        if reply.result != Result.SUCCESS:
            shown = describe_reply(reply.result, reply.subcode)
            raise FaultError(f"fault {kind} {setting}: {shown} {reply.detail}".rstrip())
        self._faults_seen = max(self._faults_seen, reply.status_seq)

    def following_error(self, group: int = 0) -> FollowingError:
        """The group's following error (commanded - feedback, per axis) over the last motion:
        the ticks in which something moved since the clock last rested. LookupError before
        anything moved."""
        ticks = self._observer.last_motion()
        if not ticks:
            raise LookupError(f"cell {self.name}: nothing moved yet")
        return following_errors(self.config, ticks)[group]

    def described(self) -> list[str]:
        if self.stopped:
            return ["stopped already (its fixture's scope ended)"]
        exited = self.running.process.poll()
        if exited is None:
            lines = self.status(REPORT_TIMEOUT_S).lines()
        else:
            lines = [f"gone: its launcher exited with {exited} before this report"]
        return [*lines, f"the end of its log ({self.log}):", log_tail(self.log, LOG_LINES)]

    def how_to_look(self) -> list[str]:
        where = f"--zenoh-connect {self.zenoh_endpoint} --credentials {self.credentials}"
        return [
            f"  motocell watch {where} --cell {self.name}",
            f"  motocell ps {where} --cell {self.name}",
            f"  its ports: motion {self.host}:{self.motion_port}, state {self.state_port},"
            f" I/O {self.io_port}; its log: {self.log}",
        ]


@contextmanager
def cell(
    config: str | Path | None = None,
    *,
    name: str | None = None,
    timeout: float = START_TIMEOUT_S,
    **settings: Any,
) -> Iterator[CellUnderTest]:
    """A started cell: ``config`` is a cell file or a sample's name (``four-group``; none: one
    6-axis arm on a YRC1000), ``settings`` set its top-level fields (``byte_order="big"``,
    ``pending_points=4``), ``name`` its name (default: unique). Stopped on exit;
    AssertionError then if any of its processes outlived the stop (they are killed first)."""
    with tempfile.TemporaryDirectory(prefix="motocell-test-cell-") as directory:
        path = write_cell_file(
            Path(directory) / "cell.toml", config, name or unique_name(), settings
        )
        log = Path(directory) / "cell.log"
        with running_cell(
            path, log=log, timeout=timeout, attempts=2, scratch=[Path(directory)]
        ) as running:
            session = running.session(Role.OPERATOR)
            started = CellUnderTest(running, session, log)
            try:
                yield started
            finally:
                started.stopped = True
                session.close()


class StartCell(Starts):
    """``start(config, name=..., timeout=..., **settings)``, as ``cell`` takes them: a cell
    started, stopped when the ``cells()`` block that made this ends."""

    def __init__(self, stack: ExitStack) -> None:
        self._stack = stack
        self._started: list[CellUnderTest] = []

    @property
    def started(self) -> tuple[CellUnderTest, ...]:
        """Every cell it started, in order."""
        return tuple(self._started)

    def __call__(
        self,
        config: str | Path | None = None,
        *,
        name: str | None = None,
        timeout: float = START_TIMEOUT_S,
        **settings: Any,
    ) -> CellUnderTest:
        started = self._stack.enter_context(cell(config, name=name, timeout=timeout, **settings))
        self._started.append(started)
        return started


@contextmanager
def cells() -> Iterator[StartCell]:
    """A function that starts a cell each time it is called (as ``cell`` does) and returns it
    started; every cell it started stops on exit, the last first."""
    with ExitStack() as stack:
        yield StartCell(stack)
