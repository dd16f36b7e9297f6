"""``motocell up`` as a user meets it at a terminal: quiet when all is well, one
line and exit status 2 for a mistake, a Ctrl-C at any moment of start-up stops everything,
and a service left out with ``--skip`` runs by hand with ``motocell service``.

Each command runs as the ``motocell`` console script does (``python -m tools``) in a session
of its own, so a Ctrl-C is what a terminal sends: SIGINT to the whole foreground process
group. Every process a command started carries a mark in its environment, so whatever is
left, reparented or not, is found.
"""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import sys
import uuid
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from motocell.shared import registry
from motocell.shared.bus.session import CONNECT_WAIT_S
from motocell.shared.config import EXIT_CONFIG, PORT_COUNT, load_cell
from motocell.shared.launcher_names import WARM_PARENT_MODULE
from motocell.shared.ports import free_port, free_port_besides, free_port_block
from motocell.shared.registry import ENV as RUNTIME_DIR_ENV
from motocell.testing.ports import on_free_port
from motocell.testing.processes import alive, cmdline, connectable, descendants, wait_until
from motocell.testing.running_cell import zenoh_router

pytestmark = pytest.mark.cell

MOTOCELL = (sys.executable, "-m", "motocell.tools")
"""The ``motocell`` command, by the entry its console script runs."""
MARK_ENV = "MOTOCELL_TEST_MARK"
DEADLINE_S = 60.0
"""A deadline for a hang, not a performance bound: a start takes a second or two."""
HOST = "127.0.0.1"
CELL = load_cell(None).name
PICKS = 20
"""How often a test chooses its ports again when another program takes one first."""


def marked(mark: str) -> set[int]:
    """Running processes whose environment carries ``mark`` (children of children included,
    and those whose parent died)."""
    found = set()
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            environ = (entry / "environ").read_bytes()
        except OSError:
            continue
        if f"{MARK_ENV}={mark}".encode() in environ.split(b"\0") and alive(int(entry.name)):
            found.add(int(entry.name))
    return found


@dataclass
class Run:
    """A ``motocell`` command running, its output (stdout and stderr) going to a file."""

    process: subprocess.Popen[bytes]
    output: Path
    mark: str

    def text(self) -> str:
        return self.output.read_text(errors="replace")

    def wait_for(self, needle: str) -> None:
        def seen() -> bool:
            if needle in self.text():
                return True
            if self.process.poll() is not None:
                raise AssertionError(f"exited ({self.process.returncode}):\n{self.text()}")
            return False

        wait_until(seen, DEADLINE_S, f"{needle!r} in the output")

    def ctrl_c(self) -> None:
        """What a terminal sends on Ctrl-C: SIGINT to the foreground process group."""
        os.killpg(self.process.pid, signal.SIGINT)

    def finish(self) -> int:
        """Its exit status, once every process it started is gone too."""
        status = self.process.wait(DEADLINE_S)
        wait_until(lambda: not marked(self.mark), DEADLINE_S, "every process it started")
        return status


@contextlib.contextmanager
def motocell(tmp_path: Path, *args: str, sigint_ignored: bool = False) -> Iterator[Run]:
    """``motocell ARGS``, with this test's registry of running cells; killed, with whatever
    it started, if the test leaves it running. ``sigint_ignored``: started as a shell script
    starts ``motocell ARGS &``, with SIGINT ignored."""
    mark = uuid.uuid4().hex
    env = {
        **os.environ,
        RUNTIME_DIR_ENV: str(tmp_path / "run"),
        "MOTOCELL_LOG": "INFO",
        "PYTHONUNBUFFERED": "1",
        MARK_ENV: mark,
    }
    output = tmp_path / f"{mark}.log"
    with output.open("wb") as out:
        process = subprocess.Popen(
            [*(IGNORING_SIGINT if sigint_ignored else ()), *MOTOCELL, *args],
            stdout=out,
            stderr=subprocess.STDOUT,
            env=env,
            start_new_session=True,
        )
    try:
        yield Run(process, output, mark)
    finally:
        for pid in marked(mark) | ({process.pid} if process.poll() is None else set()):
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
        process.wait()


IGNORING_SIGINT = ("sh", "-c", 'trap "" INT; exec "$0" "$@"')
"""What a non-interactive shell does to a command it starts with ``&``: SIGINT ignored, and
the command inherits that."""


def stop_signals_held(pid: int) -> bool:
    """Whether ``pid`` holds SIGINT blocked: ``motocell`` does from its first line until its
    handlers are in place (``shared.signals``)."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    blocked = next(line for line in status.splitlines() if line.startswith("SigBlk:"))
    return bool(int(blocked.split()[1], 16) & (1 << (signal.SIGINT - 1)))


def wait_for_stage(run: Run, moment: str, zenoh_port: int) -> None:
    """Until the ``motocell up`` of ``run`` has reached ``moment`` of its start."""
    pid = run.process.pid
    if moment in {"loading", "handlers in place"}:
        wait_until(lambda: stop_signals_held(pid), DEADLINE_S, "motocell loading")
    if moment == "handlers in place":
        wait_until(lambda: not stop_signals_held(pid), DEADLINE_S, "the launcher's handlers")
    elif moment == "router up":
        wait_until(lambda: connectable(HOST, zenoh_port), DEADLINE_S, "the router")
    elif moment == "services starting":
        wait_until(lambda: len(marked(run.mark)) > 1, DEADLINE_S, "a service process")
    elif moment == "ready":
        run.wait_for(" ready: ")


def run_to_the_end(tmp_path: Path, *args: str) -> tuple[int, str]:
    with motocell(tmp_path, *args) as run:
        return run.finish(), run.text()


def up_options(port_base: int | None = None) -> list[str]:
    """Free ports for a cell: its TCP ports (from ``port_base`` when given) and its router's."""
    if port_base is None:
        port_base = free_port_block(PORT_COUNT, HOST)
    zenoh_port = free_port_besides(range(port_base, port_base + PORT_COUNT), HOST)
    return ["--port-base", str(port_base), "--zenoh-listen", f"tcp/{HOST}:{zenoh_port}"]


@contextlib.contextmanager
def up_on_free_ports(
    tmp_path: Path,
    *args: str,
    until: str = " ready: ",
    auto: bool = False,
    own_router: bool = True,
) -> Iterator[tuple[Run, list[str]]]:
    """``motocell up ARGS`` on ports picked free (``up_options``), once its output says
    ``until``; and the port options it was given. ``auto``: ``--port-base auto`` instead (the
    launcher picks); ``own_router`` False: no ``--zenoh-listen`` (ARGS join a router). A
    launcher that refuses a port another program took between the pick and the start is
    started again on new ones (``testing.ports.on_free_port``)."""
    with contextlib.ExitStack() as stack:

        def started(port_base: int) -> tuple[Run, list[str]]:
            options = up_options(port_base)
            if auto:
                options[1] = "auto"
            if not own_router:
                options = options[:2]
            with contextlib.ExitStack() as attempt:
                run = attempt.enter_context(motocell(tmp_path, "up", *args, *options))
                run.wait_for(until)
                stack.enter_context(attempt.pop_all())
            return run, options

        yield on_free_port(started, count=PORT_COUNT, host=HOST)


def holding(port: int) -> socket.socket:
    """A socket that listens on ``port``, as another program's would; closed again when the
    port is taken already."""
    taken = socket.socket()
    try:
        taken.bind((HOST, port))
        taken.listen()
    except OSError:
        taken.close()
        raise
    return taken


def options_holding(pick: Callable[[list[str]], int]) -> tuple[list[str], socket.socket]:
    """Free ports for a cell (``up_options``) and a socket holding the one ``pick`` names. A
    port found free can be taken by another program before this test binds it: then the
    ports are chosen again."""
    for _ in range(PICKS):
        options = up_options()
        with contextlib.suppress(OSError):
            return options, holding(pick(options))
    raise RuntimeError(f"no free ports to hold in {PICKS} picks")


def clean(output: str) -> bool:
    return "Traceback" not in output and "KeyboardInterrupt" not in output


# -- quiet when all is well ----------------------------------------------------------------


def test_a_normal_start_and_stop_says_ready_once_and_warns_of_nothing(tmp_path: Path) -> None:
    with up_on_free_ports(tmp_path) as (up, options):
        port_base, endpoint = int(options[1]), options[3]
        # Ready means a client can connect now.
        assert connectable(HOST, port_base)
        assert connectable(HOST, port_base + 1)
        up.process.send_signal(signal.SIGTERM)
        assert up.finish() == 0
        output = up.text()
    ready = [line for line in output.splitlines() if " ready: " in line]
    assert len(ready) == 1, output
    assert " INFO " in ready[0]
    for part in (CELL, f"{HOST}:{port_base}", str(port_base + 1), str(port_base + 2), endpoint):
        assert part in ready[0]
    noisy = [
        line
        for line in output.splitlines()
        if (" WARNING " in line or " ERROR " in line)
        # A machine that refuses SCHED_FIFO is not all well: that warning is meant
        # (tests/e2e/test_realtime.py). Nor is a machine that delays the clock's timer.
        and "real-time priority" not in line
        and "the clock missed" not in line
    ]
    assert noisy == [], output
    assert clean(output), output


# -- a user's mistake: one line, status 2, nothing started -------------------------------------


@pytest.mark.parametrize("offset", [0, 1, 2])
def test_a_taken_tcp_port_is_one_line_and_status_2(tmp_path: Path, offset: int) -> None:
    options, held = options_holding(lambda options: int(options[1]) + offset)
    port = int(options[1]) + offset
    with held:
        status, output = run_to_the_end(tmp_path, "up", *options)
    assert status == EXIT_CONFIG, output
    assert output.splitlines() == [output.strip()], output
    assert f"{HOST}:{port}" in output
    assert "taken by another process" in output


@pytest.mark.parametrize("port_base", ["70000", "0"])
def test_a_port_base_beyond_the_port_range_is_one_line_and_status_2(
    tmp_path: Path, port_base: str
) -> None:
    # 0 is no port: refused like any other out of range, never read as the cell file's ports.
    status, output = run_to_the_end(tmp_path, "up", *up_options()[2:], "--port-base", port_base)
    assert status == EXIT_CONFIG, output
    end = int(port_base) + 2
    assert output.strip() == (
        f"motocell up: --port-base {port_base} is out of range: the motion, state and I/O ports "
        f"({port_base}-{end}) must lie within 1-65535; `--port-base auto` picks three free "
        "ports and the ready line prints them"
    )


def test_port_base_auto_takes_free_ports_and_says_which(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv(RUNTIME_DIR_ENV, str(tmp_path / "run"))  # the registry motocell() gives
    with up_on_free_ports(tmp_path, auto=True) as (up, _):
        entry = registry.find(CELL)
        assert f"motion {HOST}:{entry.port_base}, state {entry.port_base + 1}" in up.text()
        assert connectable(HOST, entry.port_base)
        assert connectable(HOST, entry.port_base + 1)
        assert connectable(HOST, entry.port_base + 2)
        up.process.send_signal(signal.SIGTERM)
        assert up.finish() == 0
    assert entry.port_base != load_cell(None).port_base


def claims_held_at_once(up: Run) -> list[bool]:
    """For each service the launcher ``up`` runs (its processes but its warm parent, as
    ``RunningCell.services`` counts them), whether it was told its bus is new."""
    lines = [cmdline(pid) for pid in descendants(up.process.pid)]
    return ["--new-bus" in line for line in lines if WARM_PARENT_MODULE not in line]


def test_an_open_bus_says_so_in_one_warning(tmp_path: Path) -> None:
    with up_on_free_ports(tmp_path, "--open-bus") as (up, _):
        # Anyone may be on an open bus: every claim settles.
        assert claims_held_at_once(up) == [False] * 5
        up.process.send_signal(signal.SIGTERM)
        assert up.finish() == 0
        output = up.text()
    warnings = [
        line
        for line in output.splitlines()
        if " WARNING " in line
        and "real-time priority" not in line  # as above
        and "the clock missed" not in line
    ]
    assert len(warnings) == 1, output
    assert "anyone who reaches its Zenoh router can move the robot" in warnings[0]


def test_a_taken_zenoh_listen_port_is_one_line_and_status_2(tmp_path: Path) -> None:
    options, held = options_holding(lambda options: int(options[3].rsplit(":", 1)[1]))
    with held:
        status, output = run_to_the_end(tmp_path, "up", *options)
    assert status == EXIT_CONFIG, output
    assert output.splitlines() == [output.strip()], output
    assert options[3] in output
    assert "taken by another process" in output


def test_a_malformed_zenoh_endpoint_is_said_without_zenohs_source_paths(tmp_path: Path) -> None:
    options = up_options()
    status, output = run_to_the_end(tmp_path, "up", *options[:2], "--zenoh-listen", "1.2.3.4")
    assert status == EXIT_CONFIG, output
    assert "1.2.3.4 is not a Zenoh endpoint: write tcp/HOST:PORT" in output
    assert ".rs" not in output
    assert output.splitlines() == [output.strip()], output


def test_a_zenoh_runtime_zenoh_cannot_read_ends_in_one_line_and_status_2(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Zenoh's own panic message comes first (printed by Rust, not ours to silence); the
    launcher's last line says what to do, with no Python traceback."""
    monkeypatch.setenv("ZENOH_RUNTIME", "(rx: handover)")
    status, output = run_to_the_end(tmp_path, "up", *up_options())
    assert status == EXIT_CONFIG, output
    assert output.splitlines()[-1].startswith(
        "motocell up: ZENOH_RUNTIME='(rx: handover)' is not a runtime Zenoh can read"
    ), output
    assert "fix it or unset it" in output
    assert "Traceback" not in output


# -- Ctrl-C at any moment --------------------------------------------------------------------


START_MOMENTS = ["loading", "handlers in place", "router up", "services starting", "ready"]
"""The stages of a start, in order, that ``wait_for_stage`` can tell from outside."""


@pytest.mark.parametrize("moment", START_MOMENTS)
def test_ctrl_c_at_any_moment_of_a_start_stops_everything_quietly(
    tmp_path: Path, moment: str
) -> None:
    """From motocell's first line ("loading") on. Before it, in Python's own start-up (twice
    where the ROS 2 wheels' bootstrapper starts Python again), a Ctrl-C is Python's to report
    (docs/topology.md, Stopping a cell): on a loaded machine that window is long enough to
    hit."""
    options = up_options()
    with motocell(tmp_path, "up", *options) as up:
        wait_for_stage(up, moment, int(options[3].rsplit(":", 1)[1]))
        up.ctrl_c()
        status = up.finish()
        output = up.text()
    assert status in (0, 130, -signal.SIGINT), output
    assert clean(output), output


@pytest.mark.parametrize("moment", START_MOMENTS)
def test_sigint_stops_a_cell_a_script_started_in_the_background(
    tmp_path: Path, moment: str
) -> None:
    """``motocell up &`` in a script inherits SIGINT ignored; ``kill -INT`` still stops it,
    however early, and nothing is left running."""
    options = up_options()
    with motocell(tmp_path, "up", *options, sigint_ignored=True) as up:
        wait_for_stage(up, moment, int(options[3].rsplit(":", 1)[1]))
        up.process.send_signal(signal.SIGINT)
        status = up.finish()
        output = up.text()
    assert status in (0, 130), output
    assert clean(output), output


@pytest.mark.parametrize("moment", ["loading", "running"])
@pytest.mark.parametrize("command", ["router", "watch"])
def test_ctrl_c_stops_the_router_and_watch_quietly(
    tmp_path: Path, command: str, moment: str
) -> None:
    endpoint = f"tcp/{HOST}:{free_port(HOST)}"
    args = ["router", "--listen", endpoint] if command == "router" else ["watch"]
    with motocell(tmp_path, *args) as run:
        if moment == "loading":  # the earliest motocell answers for, as above
            pid = run.process.pid
            wait_until(lambda: stop_signals_held(pid), DEADLINE_S, "motocell loading")
        else:
            run.wait_for("Zenoh router running" if command == "router" else "waiting for a cell")
        run.ctrl_c()
        status = run.finish()
        output = run.text()
    assert status in (0, 130, -signal.SIGINT), output
    assert clean(output), output


@pytest.mark.parametrize("command", ["up", "service"])
def test_ctrl_c_while_waiting_for_a_router_stops_at_once(tmp_path: Path, command: str) -> None:
    nowhere = f"tcp/{HOST}:{free_port(HOST)}"
    if command == "up":
        args = ["up", "--port-base", str(free_port_block(3, HOST))]
    else:
        args = ["service", "controller"]
    with motocell(tmp_path, *args, "--zenoh-connect", nowhere) as run:
        run.wait_for(f"waiting up to {CONNECT_WAIT_S:.0f} s for a Zenoh router at {nowhere}")
        run.ctrl_c()
        status = run.finish()
        output = run.text()
    # Had it waited CONNECT_WAIT_S out, it would have said that no router answers, status 2.
    assert status == 0, output
    assert "no Zenoh router answers" not in output
    assert clean(output), output


@pytest.mark.parametrize("moment", ["loading", "motion ready"])
def test_ctrl_c_during_the_demo_stops_it_and_its_cell_quietly(tmp_path: Path, moment: str) -> None:
    with motocell(tmp_path, "demo", "--duration", "5") as demo:
        # The earliest moment is motocell's first line: before it, in Python's own start-up,
        # a Ctrl-C is Python's to report (docs/topology.md, Stopping a cell).
        if moment == "loading":
            pid = demo.process.pid
            wait_until(lambda: stop_signals_held(pid), DEADLINE_S, "motocell loading")
        else:
            demo.wait_for("CHECK_MOTION_READY")
        demo.ctrl_c()
        status = demo.finish()
        output = demo.text()
    assert status in (0, 130, -signal.SIGINT), output
    assert clean(output), output


# -- nothing left behind ------------------------------------------------------------------------


@pytest.mark.parametrize("stop", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_a_cell_stopped_cleanly_leaves_no_credentials(tmp_path: Path, stop: signal.Signals) -> None:
    credentials = registry.credentials_dir(CELL, tmp_path / "run")
    with up_on_free_ports(tmp_path) as (up, _):
        assert (credentials / "users").is_file()
        up.process.send_signal(stop)
        assert up.finish() == 0
    assert list(credentials.parent.iterdir()) == []


def test_credentials_a_user_gives_are_left_as_they_are(tmp_path: Path) -> None:
    """A cell joining a router of the user's, with the user's credentials: its stop removes
    nothing of theirs."""
    given = tmp_path / "given"
    endpoint = f"tcp/{HOST}:{free_port(HOST)}"
    router = tmp_path / "router.json5"
    status, output = run_to_the_end(tmp_path, "credentials", str(given))
    assert status == 0, output
    site = ["site", str(given), "--config", "single-arm", "--listen", endpoint]
    status, output = run_to_the_end(tmp_path, *site, "--out", str(router))
    assert status == 0, output
    before = {
        path: (path.read_bytes(), path.stat().st_mode)
        for path in given.rglob("*")
        if path.is_file()
    }
    with zenoh_router(config_file=router):
        joining = ["--zenoh-connect", endpoint, "--credentials", str(given)]
        with up_on_free_ports(tmp_path, *joining, own_router=False) as (up, _):
            assert claims_held_at_once(up) == [False] * 5, "a router others may have joined"
            up.process.send_signal(signal.SIGTERM)
            assert up.finish() == 0
    after = {
        path: (path.read_bytes(), path.stat().st_mode)
        for path in given.rglob("*")
        if path.is_file()
    }
    assert after == before


# -- a service by hand -----------------------------------------------------------------------


def test_a_skipped_service_runs_by_hand_and_makes_the_cell_ready(tmp_path: Path) -> None:
    skipping = up_on_free_ports(tmp_path, "--skip", "gateway/0", until="gateway/0 not started here")
    with skipping as (up, options):
        port_base, endpoint = options[1], options[3]
        credentials = registry.credentials_dir(CELL, tmp_path / "run")
        by_hand = [
            *("service", "gateway", "--zenoh-connect", endpoint),
            *("--credentials", str(credentials), "--port-base", port_base),
        ]
        with holding(int(port_base)):
            status, output = run_to_the_end(tmp_path, *by_hand)
        assert status == EXIT_CONFIG, output
        # After its INFO line that it joined the cell: it finds the port taken only then.
        assert [line for line in output.splitlines() if " INFO " not in line] == [
            f"motocell gateway/0: cannot listen on {HOST}:{port_base}: Address already in use"
        ], output
        # The cell's ready line, not the controller's "not ready: services missing" warning.
        ready_line = f"cell {CELL} ready: "
        assert ready_line not in up.text()
        with motocell(tmp_path, *by_hand) as gateway:
            up.wait_for(ready_line)
            gateway.process.send_signal(signal.SIGTERM)
            assert gateway.finish() == 0
        up.process.send_signal(signal.SIGTERM)
        assert up.finish() == 0
