"""The per-user registry of running cells: one live cell per name, stale entries ignored."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from motocell.shared import registry
from motocell.shared.registry import CellEntry, CellNameTakenError, NoSuchCellError


@pytest.fixture(autouse=True)
def own_registry(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    monkeypatch.setenv(registry.ENV, str(tmp_path))
    yield tmp_path


def entry(name: str = "cell1", pid: int | None = None) -> CellEntry:
    return CellEntry(
        name=name,
        pid=os.getpid() if pid is None else pid,
        host="127.0.0.1",
        port_base=50240,
        zenoh_endpoint="tcp/127.0.0.1:7447",
    )


def test_a_registered_cell_is_found_and_gone_after_unregister() -> None:
    registry.register(entry())
    assert registry.find("cell1") == entry()
    registry.unregister("cell1", os.getpid())
    with pytest.raises(NoSuchCellError, match=r"running: none"):
        registry.find("cell1")


def test_a_live_name_is_refused_naming_the_running_cell() -> None:
    parent = os.getppid()
    registry.register(entry(pid=parent))
    with pytest.raises(CellNameTakenError, match=rf"pid {parent}, ports 127.0.0.1:50240-50242"):
        registry.register(entry())


def test_a_stale_entry_is_ignored_and_taken_over(dead_pid: int) -> None:
    registry.register(entry(pid=dead_pid))
    assert registry.running() == []
    registry.register(entry())
    assert registry.find("cell1").pid == os.getpid()


def test_unknown_names_list_the_running_cells() -> None:
    registry.register(entry("left"))
    registry.register(entry("right"))
    with pytest.raises(NoSuchCellError, match=r"running: left, right"):
        registry.find("middle")


def test_unregister_leaves_another_launchers_entry() -> None:
    registry.register(entry(pid=os.getppid()))
    registry.unregister("cell1", os.getpid())
    assert registry.find("cell1").pid == os.getppid()


CLAIM = """
import os, sys, time
from motocell.shared import registry
from motocell.shared.registry import CellEntry, CellNameTakenError
entry = CellEntry(name="race", pid=os.getpid(), host="h", port_base=1, zenoh_endpoint="e")
sys.stdin.readline()
try:
    registry.register(entry)
except CellNameTakenError:
    print("lost", flush=True)
else:
    print("won", flush=True)
sys.stdin.readline()
"""


@pytest.mark.cell
def test_of_many_simultaneous_claims_exactly_one_wins(own_registry: Path) -> None:
    env = {**os.environ, registry.ENV: str(own_registry)}
    claimants = [
        subprocess.Popen(
            [sys.executable, "-c", CLAIM],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            env=env,
        )
        for _ in range(8)
    ]
    try:
        for claimant in claimants:
            assert claimant.stdin is not None
            claimant.stdin.write("go\n")
            claimant.stdin.flush()
        outcomes = [claimant.stdout.readline().strip() for claimant in claimants if claimant.stdout]
        assert sorted(outcomes) == ["lost"] * 7 + ["won"]
    finally:
        for claimant in claimants:
            claimant.communicate("done\n", timeout=10)


def test_a_cell_s_credentials_go_with_its_entry() -> None:
    credentials = registry.credentials_dir("cell1")
    registry.register(entry())
    credentials.mkdir(parents=True)
    (credentials / "users").write_text("")
    registry.unregister("cell1", os.getpid())
    assert not credentials.exists()


def test_another_launcher_s_credentials_stay() -> None:
    parent = os.getppid()
    registry.register(entry(pid=parent))
    credentials = registry.credentials_dir("cell1")
    credentials.mkdir(parents=True)
    registry.unregister("cell1", os.getpid())  # not the entry this process wrote
    assert credentials.is_dir()


def test_a_registration_removes_the_credentials_of_cells_no_longer_running(
    dead_pid: int,
) -> None:
    """A killed launcher cannot remove its own; the next one removes them, and only them."""
    registry.register(entry("killed", pid=dead_pid))
    registry.register(entry("running", pid=os.getppid()))
    for name in ("killed", "running", "never-registered"):
        registry.credentials_dir(name).mkdir(parents=True)
    registry.register(entry("new"))
    remaining = sorted(path.name for path in registry.credentials_dir("new").parent.iterdir())
    assert remaining == ["running"]
