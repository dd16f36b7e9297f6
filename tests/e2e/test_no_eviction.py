"""A running service is never evicted: neither a claim token declared with a
service's password nor a second process of a service's name changes anything of a running
cell (the same processes, still answering, still moving); the second process is refused with
one line and exit status 2. The rules: shared/bus/claim.py; docs/topology.md."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from motocell.shared.bus.access import Identity
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.credentials import load
from motocell.shared.bus.session import open_session
from motocell.shared.ports import free_port_block
from motocell.testing.client import MotionClient, StateListener
from motocell.testing.processes import wait_until
from motocell.testing.running_cell import RunningCell, running_cell
from tests.e2e.test_one_cell_per_name import still_moves

pytestmark = pytest.mark.cell

START_DEADLINE_S = 60.0
SEEN_TIMEOUT_S = 20.0
"""A deadline for a hang: the holder sees a claim within milliseconds."""
REFUSAL_TIMEOUT_S = 60.0
"""A deadline for a hang, not a performance bound (docs/realtime.md has the measured times)."""


@pytest.fixture(scope="module")
def log_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("cell") / "cell.log"


@pytest.fixture(scope="module")
def cell(log_path: Path) -> Iterator[RunningCell]:
    """The default cell, its services' warnings in ``log_path``."""
    with running_cell(log=log_path, timeout=START_DEADLINE_S, attempts=2) as running:
        yield running


def processes(cell: RunningCell) -> set[int]:
    return {cell.process.pid, *cell.children()}


def test_a_claim_token_with_the_gateways_password_changes_nothing(
    cell: RunningCell, log_path: Path, motion: MotionClient, state: StateListener
) -> None:
    before = processes(cell)
    assert cell.credentials is not None
    credentials = load(cell.credentials, cell.cell.name, Identity(Role.GATEWAY))
    session = open_session("client", [cell.zenoh_endpoint], wait=False, credentials=credentials)
    try:
        tokens = [
            session.liveliness().declare_token(cell.keys.claim("gateway", "0", chunk))
            for chunk in ("0", "0.held")
        ]
        ignored = f"a later claim on gateway of cell {cell.cell.name} (session 0) is ignored"
        wait_until(
            lambda: log_path.read_text().count(ignored) == 2,
            SEEN_TIMEOUT_S,
            "the gateway to see both claims",
        )
        still_moves(motion, state)
        assert processes(cell) == before
        for token in tokens:
            token.undeclare()
    finally:
        session.close()


@pytest.mark.parametrize(
    ("service", "options"),
    [
        ("gateway", ["--port-base", str(free_port_block(3))]),
        ("executor", []),
        ("interpolator/0", []),
    ],
)
def test_a_second_process_of_a_services_name_is_refused_and_changes_nothing(
    cell: RunningCell,
    motion: MotionClient,
    state: StateListener,
    service: str,
    options: list[str],
) -> None:
    before = processes(cell)
    assert cell.credentials is not None
    command = [sys.executable, "-m", "motocell.tools.cli", "service", service, *options]
    command += ["--zenoh-connect", cell.zenoh_endpoint, "--credentials", str(cell.credentials)]
    result = subprocess.run(
        command, capture_output=True, text=True, timeout=REFUSAL_TIMEOUT_S, check=False
    )
    assert result.returncode == 2, result.stderr
    (line,) = result.stderr.strip().splitlines()
    module = service.split("/", maxsplit=1)[0]
    holder = next(iter(cell.service_pids(module, 0 if module == "interpolator" else None)))
    name = service if "/" in service else f"{service}/0"
    article = "an" if service[0] in "aeiou" else "a"
    assert line.startswith(f"motocell {name}: {article} {service} of cell {cell.cell.name}"), line
    assert "is already running on this Zenoh network (host " in line, line
    assert f"pid {holder})" in line, line
    still_moves(motion, state)
    assert processes(cell) == before
