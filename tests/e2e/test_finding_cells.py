"""The tools find the cells running on this machine by name, in the registry their launchers
write, and join each one's secured bus with that cell's own credentials: no endpoint and no
credentials on the command line. A name that does not run, or two cells where one is meant,
is refused at once with the cells that do run; a cell started elsewhere is reached with
``--zenoh-connect`` and its credentials.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from motocell.shared import registry
from motocell.shared.bus.access import cell_identities
from motocell.shared.bus.credentials import write_passwords
from motocell.shared.protocol.constants import Command, NotReadySubcode, Result
from motocell.shared.registry import ENV as RUNTIME_DIR_ENV
from motocell.testing.client import MotionClient
from motocell.testing.running_cell import (
    HOST,
    STOP_TIMEOUT_S,
    RunningCell,
    wait_for_whole_cell,
)
from tests.launched import launched, named

pytestmark = pytest.mark.cell

Motocell = Callable[..., subprocess.CompletedProcess[str]]
BESIDE = "beside"


@pytest.fixture(autouse=True)
def registry_of(cell: RunningCell, monkeypatch: pytest.MonkeyPatch) -> None:
    """This process and the commands it runs see the registry the module's cell is in."""
    monkeypatch.setenv(RUNTIME_DIR_ENV, str(cell.runtime_dir))


@pytest.fixture(scope="module")
def beside(cell: RunningCell, tmp_path_factory: pytest.TempPathFactory) -> Iterator[int]:
    """A second cell next to the module's, as ``motocell up --name beside`` starts it (its own
    router and credentials, the same registry); its motion port."""

    env = {**os.environ, RUNTIME_DIR_ENV: str(cell.runtime_dir), "MOTOCELL_LOG": "WARNING"}
    log = tmp_path_factory.mktemp("beside") / "up.log"
    process, port_base = launched(named(BESIDE), env, log)
    try:
        wait_for_whole_cell(HOST, port_base, cell.byte_order)
        yield port_base
    finally:
        process.terminate()
        try:
            process.wait(timeout=STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
            raise


def running_names() -> list[str]:
    return [entry.name for entry in registry.running()]


@pytest.mark.parametrize("command", ["ps", "watch --count 1", "record x.mcap", "fault hold on"])
def test_a_cell_that_does_not_run_is_refused_at_once_with_the_cells_that_do(
    command: str, motocell: Motocell, tmp_path: Path
) -> None:
    words = [str(tmp_path / w) if w.endswith(".mcap") else w for w in command.split()]
    result = motocell(*words, "--cell", "nosuch", timeout=15)
    assert result.returncode == 2, result.stderr
    assert result.stderr == (
        f"motocell {words[0]}: no cell named nosuch is running here "
        f"(running: {', '.join(running_names())})\n"
    )
    assert not (tmp_path / "x.mcap").exists()


def test_ps_covers_every_cell_running_here(
    cell: RunningCell, beside: int, motocell: Motocell
) -> None:
    result = motocell("ps")
    assert result.returncode == 0, result.stderr
    table, buses = result.stdout.split("\n\n")
    cells_shown = {line.split()[0] for line in table.splitlines()[1:]}
    assert cells_shown == {cell.cell.name, BESIDE}
    for name in (cell.cell.name, BESIDE):
        entry = registry.find(name)
        host, base = entry.host, entry.port_base
        line = (
            f"cell {name}: Zenoh {entry.zenoh_endpoint}, credentials {entry.credentials}; "
            f"TCP motion {host}:{base}, state {host}:{base + 1}, io {host}:{base + 2}"
        )
        assert line in buses.splitlines()
    assert registry.find(BESIDE).zenoh_endpoint != cell.zenoh_endpoint


def test_fault_refuses_to_choose_between_two_cells_and_reaches_the_one_named(
    cell: RunningCell, beside: int, motocell: Motocell
) -> None:
    with (
        cell.motion() as here,
        MotionClient(HOST, beside, cell.byte_order) as there,
    ):
        for motion in (here, there):
            assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
        refused = motocell("fault", "estop", "on")
        assert refused.returncode == 2
        assert refused.stderr == (
            f"motocell fault: 2 cells are running here ({', '.join(running_names())}): "
            "choose one with --cell\n"
        )
        assert here.command(Command.CHECK_MOTION_READY).result == Result.SUCCESS
        assert there.command(Command.CHECK_MOTION_READY).result == Result.SUCCESS

        injected = motocell("fault", "estop", "on", "--cell", BESIDE)
        assert injected.returncode == 0, injected.stderr
        ready = there.command(Command.CHECK_MOTION_READY)
        assert (ready.result, ready.subcode) == (Result.FALSE, NotReadySubcode.ESTOP)
        assert here.command(Command.CHECK_MOTION_READY).result == Result.SUCCESS
        assert motocell("fault", "estop", "off", "--cell", BESIDE).returncode == 0


def test_a_router_named_outright_needs_the_cells_current_credentials(
    cell: RunningCell, motocell: Motocell, tmp_path: Path
) -> None:
    endpoint = ("--zenoh-connect", cell.zenoh_endpoint)
    assert cell.credentials is not None
    bare = motocell("ps", *endpoint)
    assert bare.returncode == 1
    assert bare.stderr.count("\n") == 1 and "--credentials DIR" in bare.stderr, bare.stderr

    current = ("--cell", cell.cell.name, "--credentials", str(cell.credentials))
    listed = motocell("ps", *endpoint, *current)
    assert listed.returncode == 0, listed.stderr
    assert [cell.cell.name, "controller"] in [
        line.split()[:2] for line in listed.stdout.splitlines()
    ]

    # What a copy kept from an earlier run of the cell looks like: the same names, other
    # passwords (the cell writes new ones at every start).
    earlier = tmp_path / "earlier"
    shutil.copytree(cell.credentials, earlier)
    write_passwords(earlier, cell.cell.name, cell_identities(len(cell.cell.groups)))
    stale = motocell("ps", *endpoint, "--cell", cell.cell.name, "--credentials", str(earlier))
    assert stale.returncode == 1
    assert stale.stderr.count("\n") == 1, stale.stderr
    assert f"refused {cell.cell.name}.observer" in stale.stderr
