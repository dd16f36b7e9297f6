"""Where a service's version and the robot models are read: the version from the package
itself, as its installed metadata has it; the models once, by whoever imports a service's
modules (the launcher's warm parent, for all its forks), never by the launcher's own modules.
And whose claim skips the settles."""

from __future__ import annotations

import argparse
import importlib.metadata
import os
from pathlib import Path

import pytest

from motocell import __version__
from motocell.shared.config import RobotModel, load_catalogue
from motocell.shared.launcher_names import PARENT_PID_ENV
from motocell.shared.running_service import claims_at_once
from tests.tools.test_cli import loaded_after

FORKED = ("broadcaster", "controller", "executor", "gateway", "interpolator")
READ_AT_IMPORT = {"motocell.shared.running_service"}


def test_the_version_a_service_describes_itself_with_is_the_installed_one() -> None:
    assert importlib.metadata.version("motocell") == __version__


def test_the_catalogue_is_read_once_and_shared_read_only() -> None:
    catalogue = load_catalogue()
    assert catalogue is load_catalogue()
    assert "arm6" in catalogue
    with pytest.raises(TypeError):
        catalogue["arm6"] = RobotModel.__new__(RobotModel)  # type: ignore[index]


@pytest.mark.cell
def test_the_launchers_modules_do_not_read_it_and_each_services_do(tmp_path: Path) -> None:
    launcher = "import motocell.services.launcher.__main__, motocell.services.launcher.up"
    assert loaded_after(launcher, READ_AT_IMPORT, tmp_path) == []
    for service in FORKED:
        code = f"import motocell.services.{service}.__main__"
        assert loaded_after(code, READ_AT_IMPORT, tmp_path) == sorted(READ_AT_IMPORT), service


def test_only_a_launchers_child_claims_at_once_when_told_its_bus_is_new(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    told, untold = argparse.Namespace(new_bus=True), argparse.Namespace(new_bus=False)
    monkeypatch.delenv(PARENT_PID_ENV, raising=False)
    assert not claims_at_once(told), "a command line copied into a shell settles"
    monkeypatch.setenv(PARENT_PID_ENV, str(os.getppid()))
    assert claims_at_once(told)
    assert not claims_at_once(untold)
