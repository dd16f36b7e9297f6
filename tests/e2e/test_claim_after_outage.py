"""A forged claim wins nothing, before or after its router restarts (docs/topology.md, One
process per service name): a secured cell joined to a router of its own; a session with a
service's own password holds a forged held claim on its name; the router is killed and
started again; the cell is whole again with the same processes and moves. A cell started
while such a token sits on the bus either ignores it (it names no Zenoh session) or is
refused with one line naming the session that holds it."""

from __future__ import annotations

import os
import signal
import subprocess
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
import zenoh

from motocell.shared.bus.access import Identity
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.credentials import load
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.session import open_session
from motocell.shared.config import load_cell
from motocell.shared.protocol.constants import Command, Result
from motocell.testing.client import smooth_move, stream
from motocell.testing.ports import ended, on_free_port
from motocell.testing.processes import wait_until
from motocell.testing.running_cell import (
    ROUTER,
    STOP_TIMEOUT_S,
    RunningCell,
    running_cell,
    start_cell,
    wait_for_whole_cell,
)
from tests.e2e.conftest import START_DEADLINE_S

pytestmark = pytest.mark.cell

Motocell = Callable[..., subprocess.CompletedProcess[str]]

CELL_FILE = "single-arm"
SEEN_TIMEOUT_S = 20.0
"""A deadline for a hang: a holder sees a claim within milliseconds."""
REJOIN_TIMEOUT_S = 30.0
"""A Zenoh client tries its router again about once a second; generous for a loaded host."""
FORGED = {"gateway": "0", "executor": "1"}
"""A held claim per service: one on a chunk no session could have (what an adversary typed),
one on a valid session id that no process has."""


class Router:
    """The cell's secured router in a process of its own, to be killed and started again on
    the same endpoint (a port taken during the outage would fail the test: what it tests is a
    router back where the services look for it)."""

    def __init__(self, config: Path, endpoint: str) -> None:
        self.config = config
        self.endpoint = endpoint
        self.log = config.with_suffix(".log")
        self.process = self._start()

    def _start(self) -> subprocess.Popen[bytes]:
        """Once it says it runs; PortTakenError if it exits because its port is taken."""
        with self.log.open("wb") as out:
            process = subprocess.Popen(
                [*ROUTER, "--config", str(self.config)],
                env={**os.environ, "MOTOCELL_LOG": "INFO"},  # its "running" line
                stdout=out,
                stderr=out,
            )

        def running() -> bool:
            said = self.log.read_text(errors="replace")
            if process.poll() is not None:
                raise ended("the router", process.returncode, said)
            return "Zenoh router running" in said

        wait_until(running, SEEN_TIMEOUT_S, "the router to run")
        return process

    def kill_and_restart(self) -> None:
        self.process.send_signal(signal.SIGKILL)
        self.process.wait(timeout=STOP_TIMEOUT_S)
        self.process = self._start()

    def stop(self) -> None:
        self.process.terminate()
        try:
            self.process.wait(timeout=STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()


@pytest.fixture(scope="module")
def credentials(tmp_path_factory: pytest.TempPathFactory, motocell: Motocell) -> Path:
    directory = tmp_path_factory.mktemp("claim") / "credentials"
    made = motocell("credentials", str(directory), "--config", CELL_FILE)
    assert made.returncode == 0, made.stderr
    return directory


@pytest.fixture
def router(tmp_path: Path, credentials: Path, motocell: Motocell) -> Iterator[Router]:
    config = tmp_path / "router.json5"
    cell = f"{load_cell(CELL_FILE).name}={CELL_FILE}"

    def started(port: int) -> Router:
        endpoint = f"tcp/127.0.0.1:{port}"
        written = motocell(
            "site", str(credentials), "--config", cell, "--listen", endpoint, "--out", str(config)
        )
        assert written.returncode == 0, written.stderr
        return Router(config, endpoint)

    running = on_free_port(started)
    yield running
    running.stop()


@pytest.fixture
def forger(router: Router, credentials: Path) -> Iterator[dict[str, zenoh.Session]]:
    """A session per attacked service, each with that service's own password."""
    cell = load_cell(CELL_FILE).name
    sessions = {
        service: open_session(
            "client",
            [router.endpoint],
            wait=False,
            credentials=load(credentials, cell, Identity(Role(service))),
        )
        for service in FORGED
    }
    yield sessions
    for session in sessions.values():
        session.close()


def forge(sessions: dict[str, zenoh.Session], keys: CellKeys) -> list[zenoh.LivelinessToken]:
    return [
        sessions[service].liveliness().declare_token(keys.claim(service, "0", f"{chunk}.held"))
        for service, chunk in FORGED.items()
    ]


def ignored(log: Path, cell: str, service: str) -> int:
    line = f"a later claim on {service} of cell {cell} (session {FORGED[service]}) is ignored"
    return log.read_text(errors="replace").count(line)


def seen(log: Path, cell: RunningCell, times: int) -> bool:
    """Whether every attacked holder has logged its forged claim as ignored ``times`` times."""
    return all(ignored(log, cell.cell.name, service) >= times for service in FORGED)


def moves_again(cell: RunningCell) -> None:
    """START_TRAJ_MODE succeeds once every service is back, and a short move arrives."""
    wait_for_whole_cell(cell.host, cell.port_base, cell.byte_order, REJOIN_TIMEOUT_S)
    with cell.motion() as motion, cell.state() as state:
        state.wait_for(lambda f: f.status is not None, REJOIN_TIMEOUT_S)
        wait_until(
            lambda: motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS,
            REJOIN_TIMEOUT_S,
            "START_TRAJ_MODE to succeed",
        )
        start = state.wait_still().groups[0].positions[:6]
        result = stream(motion, smooth_move(start, [p + 0.05 for p in start], 0.3, 4))
        assert result.points == 4, result.last_reply


def test_a_forged_claim_held_across_a_router_restart_evicts_nobody(
    router: Router,
    credentials: Path,
    forger: dict[str, zenoh.Session],
    tmp_path: Path,
) -> None:
    log = tmp_path / "cell.log"
    with running_cell(
        CELL_FILE,
        router=router.endpoint,
        credentials=credentials,
        log=log,
        timeout=START_DEADLINE_S,
    ) as cell:
        before = {cell.process.pid, *cell.children()}
        tokens = forge(forger, cell.keys)
        wait_until(lambda: seen(log, cell, 1), SEEN_TIMEOUT_S, "the holders to see the claims")
        router.kill_and_restart()
        # Every party rejoins the new router and sends its tokens again: each holder sees the
        # forged claim once more, within the second it takes a claim made meanwhile from.
        wait_until(lambda: seen(log, cell, 2), REJOIN_TIMEOUT_S, "the holders to see them again")
        moves_again(cell)
        said = log.read_text(errors="replace")
        assert "apart from its router" not in said, said[-3000:]
        assert cell.process.poll() is None, said[-3000:]
        assert {cell.process.pid, *cell.children()} == before, said[-3000:]
        for token in tokens:
            token.undeclare()


def test_a_cell_starts_beside_a_claim_no_session_made_and_is_refused_naming_a_sessions(
    router: Router,
    credentials: Path,
    forger: dict[str, zenoh.Session],
    tmp_path: Path,
) -> None:
    keys = CellKeys(load_cell(CELL_FILE).name)
    by_hand = forger["gateway"].liveliness().declare_token(keys.claim("gateway", "0", "0.held"))
    log = tmp_path / "cell.log"
    with running_cell(
        CELL_FILE,
        router=router.endpoint,
        credentials=credentials,
        log=log,
        timeout=START_DEADLINE_S,
    ) as cell:
        assert "names no Zenoh session (0.held)" in log.read_text(errors="replace")
        assert cell.process.poll() is None
    session_id = FORGED["executor"]
    held = (
        forger["executor"]
        .liveliness()
        .declare_token(keys.claim("executor", "0", f"{session_id}.held"))
    )
    refused = tmp_path / "refused.log"
    launcher = start_cell(CELL_FILE, router=router.endpoint, credentials=credentials, log=refused)
    try:
        assert launcher.process.wait(timeout=START_DEADLINE_S) == 2
    finally:
        launcher.stop()
    said = refused.read_text(errors="replace")
    lines = [line for line in said.splitlines() if line.startswith("motocell executor/0: ")]
    assert len(lines) == 1, said
    assert (
        f"running on this Zenoh network as session {session_id}, which does not answer" in lines[0]
    ), said
    assert "Traceback" not in said, said
    for token in (held, by_hand):
        token.undeclare()
