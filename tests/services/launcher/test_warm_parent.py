"""The warm parent started as the launcher's first act (services/launcher/warm_parent.py)."""

from __future__ import annotations

from pathlib import Path
from typing import cast

import pytest

from motocell.services.launcher.up import warm_starter
from motocell.services.launcher.warm_parent import StartedZygote, started_zygote
from motocell.shared.service import StopFlag
from motocell.shared.service_names import ROS2_FACE, WARM_MODULES, ServiceName
from motocell.shared.signals import STOP_SIGNALS, hold_stop_signals, release_stop_signals
from motocell.testing.processes import wait_until
from tests.tools.test_cli import loaded_after

HEAVY = {
    *("zenoh", "msgspec", "numpy", "dataclasses", "logging", "argparse"),
    *("motocell.shared.config", "motocell.shared.service", "motocell.shared.service_names"),
}
"""What the launcher loads after the zygote has started: loaded before, it would delay it."""
UNUSED = {
    *("importlib.resources", "zipfile", "tempfile", "difflib"),
    *("secrets", "hmac", "hashlib"),
}
"""What neither the launcher nor the warm parent needs to start a cell, each a few ms of CPU at
every start (docs/startup.md, The critical path): the package data's reader, the suggestion for
a misspelt field, the hashing that ``secrets`` brings to make a password."""
LAUNCHER_START = (
    "import motocell.services.launcher.__main__, motocell.services.launcher.up\n"
    "from pathlib import Path\n"
    "from motocell.shared.bus.access import cell_identities\n"
    "from motocell.shared.bus.credentials import write_passwords\n"
    "from motocell.shared.config import load_cell\n"
    "load_cell('single-arm')\n"
    "write_passwords(Path('credentials'), 'cell1', cell_identities(1))"
)
"""What a launcher does before its router opens: its modules, its cell file, its passwords."""
WARM_UP = (
    "from motocell.services.launcher.zygote import warm_up\n"
    "from motocell.shared.service_names import WARM_MODULES\n"
    "warm_up(WARM_MODULES)"
)
DEADLINE_S = 30.0
"""For a hang: the zygote releases them within a few tenths of a second."""


@pytest.mark.parametrize("word", ["--cold", "--help", "-h", "--version"])
def test_a_run_that_forks_nothing_starts_no_zygote(word: str) -> None:
    with started_zygote(["--name", "cell1", word]) as zygote:
        assert zygote is None


def test_the_zygote_holds_every_service_but_the_ros2_face() -> None:
    assert "motocell.services.executor" in WARM_MODULES
    assert "motocell.services.interpolator" in WARM_MODULES
    assert "motocell.services.ros2" not in WARM_MODULES


@pytest.mark.cell
@pytest.mark.parametrize(
    "module", ["motocell.services.launcher.warm_parent", "motocell.services.launcher.__main__"]
)
def test_starting_it_loads_nothing_heavy(module: str, tmp_path: Path) -> None:
    assert loaded_after(f"import {module}", HEAVY, tmp_path) == []


@pytest.mark.cell
def test_starting_a_cell_loads_nothing_it_does_not_use(tmp_path: Path) -> None:
    assert loaded_after(LAUNCHER_START, UNUSED, tmp_path) == []
    assert loaded_after(WARM_UP, UNUSED, tmp_path) == []


def blocked_signals(pid: int) -> int:
    status = Path(f"/proc/{pid}/status").read_text()
    return int(
        next(line for line in status.splitlines() if line.startswith("SigBlk:")).split()[1], 16
    )


@pytest.mark.cell
def test_the_zygote_takes_back_the_signals_its_launcher_held() -> None:
    """Started while the launcher holds SIGINT and SIGTERM, it releases them, so that the
    SIGTERM its PR_SET_PDEATHSIG sends when the launcher dies ends it."""
    stop_bits = sum(1 << (sig - 1) for sig in STOP_SIGNALS)
    hold_stop_signals()
    try:
        zygote = StartedZygote()
    finally:
        release_stop_signals()
    try:
        assert blocked_signals(zygote.process.pid) & stop_bits == stop_bits  # as it started
        wait_until(
            lambda: blocked_signals(zygote.process.pid) & stop_bits == 0,
            DEADLINE_S,
            "the zygote to release SIGINT and SIGTERM",
        )
    finally:
        zygote.close()


class UnusedZygote:
    """A started zygote's stand-in: whether it was closed."""

    def __init__(self) -> None:
        self.closed = False

    def close(self) -> None:
        self.closed = True


def test_a_host_that_runs_nothing_it_forks_closes_the_zygote_at_once() -> None:
    started = UnusedZygote()
    only_the_face = [ServiceName(ROS2_FACE, "0")]
    with warm_starter(cast(StartedZygote, started), only_the_face, StopFlag()) as starter:
        assert started.closed
        assert starter.pids() == set()
