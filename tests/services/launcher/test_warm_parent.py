"""The warm parent started as the launcher's first act (services/launcher/warm_parent.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from motocell.services.launcher.warm_parent import WARM_MODULES, started_zygote
from tests.tools.test_cli import loaded_after

HEAVY = {"zenoh", "msgspec", "numpy", "motocell.shared.config", "motocell.shared.service"}
"""What the launcher loads after the zygote has started: loaded before, it would delay it."""


@pytest.mark.parametrize("word", ["--cold", "--help", "-h", "--version"])
def test_a_run_that_forks_nothing_starts_no_zygote(word: str) -> None:
    with started_zygote(["--name", "cell1", word]) as zygote:
        assert zygote is None


def test_the_zygote_holds_every_service_but_the_ros2_face() -> None:
    assert "motocell.services.executor" in WARM_MODULES
    assert "motocell.services.interpolator" in WARM_MODULES
    assert "motocell.services.ros2" not in WARM_MODULES


@pytest.mark.cell
def test_starting_it_loads_nothing_heavy(tmp_path: Path) -> None:
    code = "import motocell.services.launcher.warm_parent"
    assert loaded_after(code, HEAVY, tmp_path) == []
