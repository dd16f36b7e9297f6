"""The warm parent forked from the launcher (services/launcher/warm_parent.py), and the launcher's
first lines before it (services/launcher/__main__.py)."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import cast

import pytest

from motocell.services.launcher.__main__ import needs_room
from motocell.services.launcher.up import warm_starter
from motocell.services.launcher.warm_parent import StartedZygote
from motocell.shared.launcher_names import (
    LAUNCHER_MODULE,
    ROOM,
    WARM_PARENT_MODULE,
    launcher_command,
    with_room,
    without_room,
)
from motocell.shared.service import StopFlag
from motocell.shared.service_names import ROS2_FACE, WARM_MODULES, ServiceName
from motocell.shared.signals import STOP_SIGNALS
from motocell.testing.processes import cmdline, wait_until
from tests.tools.test_cli import loaded_after

HEAVY = {
    *("zenoh", "msgspec", "numpy", "dataclasses", "logging", "argparse"),
    *("motocell.shared.config", "motocell.shared.service", "motocell.shared.service_names"),
}
"""What the launcher loads only once it knows it has room for its forks' command lines: loaded
before, it would load them twice when it starts its interpreter again to make that room."""
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
def test_a_run_that_forks_nothing_needs_no_room(word: str) -> None:
    assert not needs_room(["--name", "cell1", word])
    assert needs_room(["--name", "cell1"])


def test_the_room_comes_and_goes_with_the_interpreters_own_options() -> None:
    command = ["python3", "-W", "error", "-m", LAUNCHER_MODULE, "--name", "cell1"]
    roomy = with_room(command)
    assert roomy[:2] == [sys.executable, "-X"]
    assert len(roomy[2]) > ROOM
    assert roomy[3:] == command[1:]
    assert without_room(roomy) == [sys.executable, *command[1:]]
    assert without_room(command) == command


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


FORKING = (
    "import sys\n"
    "from motocell.shared.signals import hold_stop_signals\n"
    "hold_stop_signals()\n"
    "from motocell.services.launcher.warm_parent import fork_zygote\n"
    "zygote = fork_zygote()\n"
    "print(zygote.process.pid, flush=True)\n"
    "sys.stdin.read()\n"
    "zygote.close()\n"
)
"""A launcher's first lines: its signals held, its zygote forked; it ends, with its zygote, when
its standard input does."""


@pytest.fixture
def forking_launcher() -> Iterator[tuple[subprocess.Popen[str], int]]:
    """A process that has forked a zygote, and the zygote's pid."""
    with subprocess.Popen(
        [*launcher_command()[:-2], "-c", FORKING],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    ) as launcher:
        assert launcher.stdin is not None and launcher.stdout is not None
        try:
            yield launcher, int(launcher.stdout.readline())
        finally:
            launcher.stdin.close()
            launcher.wait(DEADLINE_S)


@pytest.mark.cell
def test_the_zygote_takes_back_the_signals_its_launcher_held(
    forking_launcher: tuple[subprocess.Popen[str], int],
) -> None:
    """Forked while the launcher holds SIGINT and SIGTERM, it releases them, so that the
    SIGTERM its PR_SET_PDEATHSIG sends when the launcher dies ends it."""
    _, zygote = forking_launcher
    stop_bits = sum(1 << (sig - 1) for sig in STOP_SIGNALS)
    wait_until(
        lambda: blocked_signals(zygote) & stop_bits == 0,
        DEADLINE_S,
        "the zygote to release SIGINT and SIGTERM",
    )


@pytest.mark.cell
def test_the_zygote_names_its_module_and_holds_nothing_of_its_launchers(
    forking_launcher: tuple[subprocess.Popen[str], int],
) -> None:
    launcher, zygote = forking_launcher
    wait_until(
        lambda: cmdline(zygote) == [sys.executable, "-m", WARM_PARENT_MODULE],
        DEADLINE_S,
        "the zygote to write its command line",
    )
    held = {int(fd) for fd in os.listdir(f"/proc/{zygote}/fd")}
    assert len(held) == 4  # its standard streams and its end of the socket
    assert os.readlink(f"/proc/{zygote}/fd/0") == os.readlink(f"/proc/{launcher.pid}/fd/0")


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
