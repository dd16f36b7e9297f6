"""Real cells on free loopback ports, for the tests, the benchmarks and the demo.

``running_cell`` starts the launcher (``python -m motocell.services.launcher``, what ``motocell up``
runs) as a child process, waits until the cell is whole, and on exit stops it and proves that
no process it started is left. Each cell gets its own Zenoh router on a free port (never the
well-known 7447, never multicast) and its own registry of running cells, so cells started here
cannot see each other, nor a cell someone runs on this machine.

Nothing here depends on the current directory or a source checkout: the processes are modules
of the installed motocell, so the harness works from a wheel as well as from the repository.
"""

from __future__ import annotations

import contextlib
import itertools
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Generic, TypeVar

import zenoh

from motocell.shared import registry
from motocell.shared.bus.access import Identity
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.credentials import load
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import Decoder, Tick
from motocell.shared.bus.session import open_session
from motocell.shared.config import PORT_COUNT, Cell, load_cell
from motocell.shared.launcher_names import WARM_PARENT_MODULE, launcher_command
from motocell.shared.ports import free_port, free_port_block, port_free
from motocell.shared.protocol.codec import ByteOrder
from motocell.shared.protocol.constants import Command, NotReadySubcode, Result
from motocell.shared.registry import ENV as RUNTIME_DIR_ENV
from motocell.shared.service_names import ROS2_FACE, cell_services, parse_service
from motocell.testing.client import MotionClient, StateListener, smooth_move, stream
from motocell.testing.ports import PortTakenError, on_free_port
from motocell.testing.processes import alive, cmdline, connectable, descendants, wait_until

LAUNCHER = tuple(launcher_command())
"""What ``motocell up`` runs, by the Python that runs the harness, with the room its forks need
(``launcher_names.ROOM``), so that it does not start its interpreter again to make it."""
ROUTER = (sys.executable, "-m", "motocell.tools.cli", "router")
"""``motocell router``: a Zenoh router of its own, for cells that join one."""

HOST = "127.0.0.1"
START_TIMEOUT_S = 30.0
STOP_TIMEOUT_S = 10.0
"""The launcher stops its services within 5 s of SIGTERM; twice that is a hang."""
EXIT_TIMEOUT_S = 5.0
LOG_LEVEL = os.environ.get("MOTOCELL_TEST_LOG", "WARNING")
"""The services' log level: quiet by default, so a test's or benchmark's output is its own."""


@dataclass
class RunningCell:
    """A cell the harness started: where to reach it, and the launcher that runs it."""

    cell: Cell
    config: str | None
    """The cell file (``None``: the default cell)."""
    host: str
    port_base: int
    zenoh_endpoint: str
    process: subprocess.Popen[bytes]
    """The launcher."""
    spawned_ns: int
    """When the launcher was spawned (CLOCK_MONOTONIC)."""
    runtime_dir: Path
    """Where its launcher registers it (``shared.registry``): a directory of its own, so its
    name never clashes with a cell running elsewhere on this machine."""
    expected_children: int
    lifeline: int | None = None
    """The write end of the launcher's lifeline (``--lifeline``), held by this process alone:
    when it closes, because ``stop`` closed it or because this process died, the cell stops."""
    joined_router: bool = False
    """It joined a router started elsewhere, instead of running its own."""
    joined_credentials: Path | None = None
    """The credentials it joined that router with (None: the router is open)."""
    _seen: set[int] = field(default_factory=set, init=False, repr=False)

    @property
    def byte_order(self) -> ByteOrder:
        return ByteOrder(self.cell.byte_order)

    @property
    def keys(self) -> CellKeys:
        return CellKeys(self.cell.name)

    @property
    def credentials(self) -> Path | None:
        """The cell's credentials directory; None when it joined an open router."""
        if self.joined_router:
            return self.joined_credentials
        return registry.credentials_dir(self.cell.name, self.runtime_dir)

    def session(self, role: Role = Role.OBSERVER) -> zenoh.Session:
        """A Zenoh client of the cell's bus as ``role`` (observer: read-only; operator: may
        also inject faults). The caller closes it."""
        directory = self.credentials
        credentials = None if directory is None else load(directory, self.cell.name, Identity(role))
        return open_session("client", [self.zenoh_endpoint], wait=False, credentials=credentials)

    def motion(self) -> MotionClient:
        return MotionClient(self.host, self.port_base, self.byte_order)

    def io(self) -> MotionClient:
        return MotionClient(self.host, self.port_base + 2, self.byte_order)

    def state(self) -> StateListener:
        return StateListener(self.host, self.port_base + 1, self.byte_order).start()

    def children(self) -> set[int]:
        """The launcher's processes now (remembered, so ``stop`` can prove they exited)."""
        current = descendants(self.process.pid)
        self._seen |= current
        return current

    def services(self) -> set[int]:
        """The cell's service processes now: the launcher's, but its warm parent."""
        return {pid for pid in self.children() if WARM_PARENT_MODULE not in cmdline(pid)}

    def service_pids(self, module: str, group: int | None = None) -> set[int]:
        """The cell's processes running ``services.<module>`` (only ``group``'s, if given)."""
        found = set()
        for pid in self.children():
            argv = cmdline(pid)
            if f"motocell.services.{module}" not in argv:
                continue
            if group is None or ("--group", str(group)) in itertools.pairwise(argv):
                found.add(pid)
        return found

    def wait_started(self, timeout: float = START_TIMEOUT_S) -> None:
        """Until the launcher has started every service process it runs. ChildProcessError if
        the launcher exits first (a bad cell file, its router's port taken)."""

        def started() -> bool:
            if self.process.poll() is not None:
                raise ChildProcessError(f"the launcher exited with {self.process.returncode}")
            return len(self.services()) >= self.expected_children

        wait_until(started, timeout, "every service process to start")

    def stop(self) -> None:
        """SIGTERM to the launcher, which stops its services. AssertionError if the launcher or
        any service outlives its deadline (killed first, so nothing is left either way)."""
        self.children()
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
        problems = []
        try:
            wait_until(lambda: self.process.poll() is not None, STOP_TIMEOUT_S, "the launcher")
        except TimeoutError:
            self.process.kill()
            problems.append(f"the launcher did not stop within {STOP_TIMEOUT_S} s of SIGTERM")
        self.process.wait()
        if self.lifeline is not None:
            os.close(self.lifeline)
            self.lifeline = None
        try:
            wait_until(self._services_gone, EXIT_TIMEOUT_S, "every service process to exit")
        except TimeoutError:
            left = sorted(pid for pid in self._seen if alive(pid))
            for pid in left:
                with contextlib.suppress(ProcessLookupError):
                    os.kill(pid, signal.SIGKILL)
            problems.append(f"service processes {left} outlived the launcher")
        shutil.rmtree(self.runtime_dir, ignore_errors=True)
        if problems:
            raise AssertionError("; ".join(problems))

    def ports_taken(self) -> list[int]:
        """Which of the ports this cell was to listen on (its TCP ports, its own router's) are
        held now: once it stopped, by another process, which took them before the cell could."""
        ports = list(range(self.port_base, self.port_base + PORT_COUNT))
        if not self.joined_router:
            ports.append(int(self.zenoh_endpoint.rsplit(":", 1)[1]))
        return [port for port in ports if not port_free(port, self.host)]

    def _services_gone(self) -> bool:
        return not any(alive(pid) for pid in self._seen)


def start_cell(
    config: str | Path | None = None,
    *,
    router: str | None = None,
    credentials: Path | None = None,
    skip: Sequence[str] = (),
    log: Path | None = None,
    log_level: str = LOG_LEVEL,
    scratch: Sequence[Path] = (),
    port_base: int | None = None,
    cold: bool = False,
) -> RunningCell:
    """Spawn the launcher on free ports (``port_base``: on that one and the two after it) and
    return at once. It runs its own router, or joins
    ``router`` (secured: with ``credentials``); ``skip``ped services are the caller's to run.
    ``log``: the launcher's and its services' output goes there (appended) instead of this
    process's. ``scratch``: directories the caller made for this cell alone, which the
    launcher removes if this process dies with the cell running. ``cold``: every service a fresh
    interpreter instead of a fork of the launcher's warm parent (``motocell up --cold``).

    The cell dies with this process, however it ends (SIGKILL, the OOM killer included): the
    launcher holds the read end of a pipe whose write end only this process holds
    (``RunningCell.lifeline``), stops the cell when it reads end of file, and removes the
    cell's run directory and ``scratch``. It runs in a process group of its own, so that a
    signal to this process's group (a terminal's Ctrl-C, a CI job cancelled) reaches this
    process, whose tear-down stops the cell in order, and not the launcher in the middle of
    a test."""
    cell_file = None if config is None else str(config)
    cell = load_cell(cell_file)
    if port_base is None:
        port_base = free_port_block(3, HOST)
    endpoint = router or f"tcp/{HOST}:{_port_outside(port_base, 3)}"
    zenoh_option = "--zenoh-connect" if router else "--zenoh-listen"
    command = [*LAUNCHER, "--port-base", str(port_base), zenoh_option, endpoint]
    for service in skip:
        command += ["--skip", service]
    if credentials is not None:
        command += ["--credentials", str(credentials)]
    if cell_file is not None:
        command += ["--config", cell_file]
    if cold:
        command.append("--cold")
    # Named after this process: should the launcher too be killed outright, the next test run
    # can tell the directory is left over (the test suite's tests/leftovers.py).
    runtime_dir = Path(tempfile.mkdtemp(prefix=f"motocell-cell-{os.getpid()}-"))
    for directory in (runtime_dir, *scratch):
        command += ["--lifeline-scratch", str(directory)]
    env = {**os.environ, "MOTOCELL_LOG": log_level, RUNTIME_DIR_ENV: str(runtime_dir)}
    spawned_ns = time.monotonic_ns()
    try:
        if log is None:
            process, lifeline = spawn_with_lifeline(command, env)
        else:
            with log.open("ab") as out:
                process, lifeline = spawn_with_lifeline(command, env, out)
    except BaseException:
        shutil.rmtree(runtime_dir, ignore_errors=True)
        raise
    expected = len(cell_services(cell)) - len(skip)
    return RunningCell(
        *(cell, cell_file, HOST, port_base, endpoint, process, spawned_ns, runtime_dir, expected),
        lifeline=lifeline,
        joined_router=router is not None,
        joined_credentials=credentials,
    )


def spawn_with_lifeline(
    command: list[str], env: dict[str, str], out: IO[bytes] | None = None
) -> tuple[subprocess.Popen[bytes], int]:
    """Start ``command`` (``motocell up`` or ``motocell router``) with ``--lifeline``, in a
    process group of its own, its output to ``out`` (None: this process's); the process and
    the write end of its lifeline, which only this process holds: closed, the process stops."""
    # Neither end is inherited by a process started later (os.pipe's are not inheritable), so
    # no other child of this process keeps the lifeline open.
    lifeline_read, lifeline = os.pipe()
    try:
        process = subprocess.Popen(
            [*command, "--lifeline", str(lifeline_read)],
            env=env,
            stdout=out,
            stderr=None if out is None else subprocess.STDOUT,
            pass_fds=(lifeline_read,),
            process_group=0,
        )
    except BaseException:
        os.close(lifeline)
        raise
    finally:
        os.close(lifeline_read)
    return process, lifeline


def _port_outside(base: int, count: int) -> int:
    """A free port not among ``base``.. ``base + count - 1`` (chosen but not yet bound)."""
    while True:
        port = free_port(HOST)
        if not base <= port < base + count:
            return port


@contextmanager
def running_cell(
    config: str | Path | None = None,
    *,
    router: str | None = None,
    credentials: Path | None = None,
    skip: Sequence[str] = (),
    log: Path | None = None,
    log_level: str = LOG_LEVEL,
    timeout: float = START_TIMEOUT_S,
    attempts: int = 1,
    scratch: Sequence[Path] = (),
) -> Iterator[RunningCell]:
    """A started cell (see ``start_cell``), whole unless services are skipped; stopped on exit,
    also on errors and Ctrl-C. A start that fails because one of its ports was taken between
    choosing and binding it is tried again on new ports (``testing.ports.on_free_port``); one
    that fails otherwise is tried ``attempts`` times in all, also on new ports."""

    def started(port_base: int) -> RunningCell:
        running = start_cell(
            config,
            router=router,
            credentials=credentials,
            skip=skip,
            log=log,
            log_level=log_level,
            scratch=scratch,
            port_base=port_base,
        )
        try:
            running.wait_started(timeout)
            if not any(parse_service(text, running.cell).service != ROS2_FACE for text in skip):
                # Whole but for its ROS 2 face, which motion does not wait for.
                wait_for_whole_cell(running.host, running.port_base, running.byte_order, timeout)
        except (TimeoutError, OSError) as exc:
            running.stop()
            taken = running.ports_taken()
            if taken:
                raise PortTakenError(f"ports {taken} were taken meanwhile ({exc})") from exc
            raise
        except BaseException:
            running.stop()
            raise
        return running

    attempt = 1
    while True:
        try:
            running = on_free_port(started, count=PORT_COUNT, host=HOST)
            break
        except (TimeoutError, OSError) as exc:
            if attempt == attempts:
                if log is not None:
                    exc.add_note(f"the end of {log}:\n{log_tail(log)}")
                raise
            print(f"warning: the cell did not start ({exc}); again on new ports", file=sys.stderr)
            attempt += 1
    try:
        yield running
    finally:
        running.stop()


def wait_for_whole_cell(
    host: str, port_base: int, byte_order: ByteOrder, timeout: float = START_TIMEOUT_S
) -> None:
    """Every service is up: state flows and motion-ready no longer reports a missing service
    (INC_MOVE_ERROR); START_TRAJ_MODE can then succeed."""
    wait_until(lambda: connectable(host, port_base + 1), timeout, "the state port to listen")
    with StateListener(host, port_base + 1, byte_order).start() as state:
        state.wait_for(lambda f: f.status is not None and f.status.drives_powered != -1, timeout)
    # The state port is the broadcaster's, the motion port the gateway's: either can be first.
    # Connected once, without a probe first, whose close the gateway would make this wait for.
    with MotionClient.once_listening(host, port_base, byte_order, timeout) as motion:
        wait_until(
            lambda: (
                motion.command(Command.CHECK_MOTION_READY).subcode != NotReadySubcode.INC_MOVE_ERROR
            ),
            timeout,
            "every service of the cell to be alive",
        )


def log_tail(path: Path, lines: int = 20) -> str:
    """The last ``lines`` lines of the log at ``path``, or why it cannot be read."""
    try:
        return "\n".join(path.read_text(errors="replace").splitlines()[-lines:])
    except OSError as exc:
        return f"(unreadable: {exc})"


@contextmanager
def zenoh_router(listen: str = "", config_file: Path | None = None) -> Iterator[str]:
    """A Zenoh router in a process of its own: open on ``listen``, or as ``config_file``
    says (as ``zenohd -c``); stopped on exit, and with this process, however it ends (its
    lifeline, as ``start_cell``'s launcher has)."""
    with _router(["--config", str(config_file)] if config_file else ["--listen", listen]):
        yield listen


MAX_ROUTER_OUTPUT = 64 * 1024
"""What of a router's output is read for its first lines."""


def _listening_on(endpoint: str) -> list[str]:
    return ["--listen", endpoint]


@contextmanager
def router_on_free_port(
    host: str = HOST,
    scheme: str = "tcp",
    configure: Callable[[str], list[str]] = _listening_on,
) -> Iterator[str]:
    """A Zenoh router as ``zenoh_router`` starts it, open on ``scheme/host:PORT`` with PORT
    picked free, once it runs: its endpoint. ``configure(endpoint)``: the router's options for
    that endpoint (by default ``--listen`` it; or write a configuration file that listens there
    and give ``--config``). Started again on a new port when another process took that one
    first (``testing.ports.on_free_port``)."""
    with ExitStack() as stack:

        def started(port: int) -> str:
            endpoint = f"{scheme}/{host}:{port}"
            with ExitStack() as attempt:
                # Its output in a file with no name: nothing of it is left, however this ends.
                out = attempt.enter_context(tempfile.TemporaryFile())
                process = attempt.enter_context(_router(configure(endpoint), out, "INFO"))

                def running() -> bool:
                    said = os.pread(out.fileno(), MAX_ROUTER_OUTPUT, 0).decode(errors="replace")
                    if process.poll() is not None:
                        raise ChildProcessError(
                            f"the router exited with {process.returncode}: {said}"
                        )
                    return "Zenoh router running" in said

                wait_until(running, START_TIMEOUT_S, f"the router to listen on {endpoint}")
                stack.enter_context(attempt.pop_all())
            return endpoint

        yield on_free_port(started, host=host)


@contextmanager
def _router(
    where: list[str], out: IO[bytes] | None = None, log_level: str = LOG_LEVEL
) -> Iterator[subprocess.Popen[bytes]]:
    env = {**os.environ, "MOTOCELL_LOG": log_level}
    process, lifeline = spawn_with_lifeline([*ROUTER, *where], env, out)
    try:
        yield process
    finally:
        process.send_signal(signal.SIGTERM)
        try:
            process.wait(timeout=STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
            raise AssertionError(f"the router did not stop within {STOP_TIMEOUT_S} s") from None
        finally:
            os.close(lifeline)


T = TypeVar("T")


class SampleLog(Generic[T]):
    """Every sample on ``key``, decoded as ``payload_type``, as any Zenoh observer sees it."""

    def __init__(self, session: zenoh.Session, key: str, payload_type: type[T]) -> None:
        self.samples: list[T] = []
        self.lock = threading.Lock()
        decoder = Decoder(payload_type)

        def store(sample: zenoh.Sample) -> None:
            decoded = decoder.decode(sample.payload.to_bytes())
            with self.lock:
                self.samples.append(decoded)

        self.subscriber = session.declare_subscriber(key, store)

    def since(self, index: int) -> list[T]:
        with self.lock:
            return self.samples[index:]

    def __len__(self) -> int:
        with self.lock:
            return len(self.samples)


class TickLog(SampleLog[Tick]):
    """Every executor tick."""

    def __init__(self, session: zenoh.Session, keys: CellKeys) -> None:
        super().__init__(session, keys.executor_tick, Tick)


SWING = 0.3
"""Radians (or metres) every axis of group 0 swings by in ``moving``: well inside every model's
range from its initial position."""


@contextmanager
def moving(cell: RunningCell, seconds: float) -> Iterator[None]:
    """Group 0 swings out and back for about ``seconds``, streamed by a thread of its own as a
    ROS driver would (START_TRAJ_MODE, then points, BUSY resent). The executor's clock ticks every
    period only while something moves; at rest it publishes its resting tick once a second, so
    what needs the tick stream (a rate, a backlog) needs motion. Joined on exit."""
    axes = cell.cell.groups[0].axes
    with cell.state() as state, cell.motion() as motion:
        reply = motion.command(Command.START_TRAJ_MODE)
        if reply.result != Result.SUCCESS:
            raise AssertionError(f"START_TRAJ_MODE: result {reply.result}, {reply.subcode}")
        start = tuple(state.wait_still().groups[0].positions[:axes])
        away = tuple(position + SWING for position in start)
        legs = [
            smooth_move(start, away, duration=seconds / 2, points=11),
            smooth_move(away, start, duration=seconds / 2, points=11),
        ]
        streamer = threading.Thread(
            target=lambda: [stream(motion, leg) for leg in legs], name="cell-mover"
        )
        streamer.start()
        try:
            yield
        finally:
            streamer.join()
