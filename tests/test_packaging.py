"""The sdist and the wheel hold what a cell needs: each is built, installed into a fresh venv,
and a cell is started from it.

The sdist is built from a copy of the source tree (the tree itself is left alone) and the wheel
from that sdist, as `python -m build` does, so a file the sdist lacks fails the wheel too. Each
venv gets the artifact and its declared dependencies the way `scripts/setup` gets them (pip,
with this machine's configuration), and runs with the venv's own Python from a directory
outside the source tree, so nothing of the checkout can stand in for the installed package.
The layout these artifacts come from: ARCHITECTURE.md, Code layout."""

from __future__ import annotations

import re
import shutil
import sys
import tarfile
import zipfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.installed import (
    INSTALL_TIMEOUT_S,
    PROJECT_FILES,
    cell_starts_and_stops,
    clean_env,
    run,
)

pytestmark = [pytest.mark.cell, pytest.mark.timeout(1800)]

HOST = "127.0.0.1"


def test_the_sdist_holds_the_package_and_no_tests(artifacts: dict[str, Path]) -> None:
    with tarfile.open(artifacts["sdist"]) as sdist:
        names = {name.split("/", 1)[1] for name in sdist.getnames() if "/" in name}
    assert {*PROJECT_FILES, "motocell/__init__.py", "motocell/shared/models.toml"} <= names
    assert "motocell/services/gateway/__main__.py" in names
    assert "motocell/tools/layouts/motocell-layout.json" in names
    assert not [name for name in names if name.startswith("tests")], "tests in the sdist"
    assert not [name for name in names if "__pycache__" in name]


def test_the_wheel_holds_one_package_and_the_license(artifacts: dict[str, Path]) -> None:
    with zipfile.ZipFile(artifacts["wheel"]) as wheel:
        names = wheel.namelist()
    tops = {name.split("/", 1)[0] for name in names}
    assert {top for top in tops if not top.endswith(".dist-info")} == {"motocell"}
    assert any(re.search(r"\.dist-info/licenses/LICENSE$", name) for name in names)
    assert "motocell/shared/cells/four-group.toml" in names
    assert "motocell/tools/layouts/motocell-layout.json" in names  # Foxglove's, for the view
    # The ROS 2 interface definitions, each package whole (its build files and licence).
    definitions = "motocell/shared/ros2/definitions"
    for name in ("industrial_msgs/msg/RobotStatus.msg", "tf2_msgs/LICENSE", "README.md"):
        assert f"{definitions}/{name}" in names
    assert f"{definitions}/motoros2_interfaces/LICENSES/Apache-2.0.txt" in names
    assert f"{definitions}/control_msgs/CMakeLists.txt" in names


@pytest.fixture(scope="module", params=["wheel", "sdist"])
def venv(
    request: pytest.FixtureRequest,
    artifacts: dict[str, Path],
    tmp_path_factory: pytest.TempPathFactory,
) -> Iterator[Path]:
    """A fresh venv with the artifact and its dependencies installed."""
    kind: str = request.param
    home = tmp_path_factory.mktemp(f"venv-{kind}")
    env = clean_env()
    run([sys.executable, "-m", "venv", home], INSTALL_TIMEOUT_S, home, env)
    pip: list[str | Path] = [home / "bin" / "python", "-m", "pip", "install", "--quiet"]
    run([*pip, artifacts[kind]], INSTALL_TIMEOUT_S, home, env)
    yield home
    shutil.rmtree(home, ignore_errors=True)


def test_the_installed_package_is_the_artifact(venv: Path) -> None:
    python = venv / "bin" / "python"
    where = run(
        [
            python,
            "-c",
            "import motocell.services, motocell.shared; print(motocell.shared.__file__)",
        ],
        60.0,
        venv,
        clean_env(),
    )
    assert Path(where.strip()).resolve().is_relative_to(venv.resolve()), where
    usage = run([python, "-m", "motocell.services.controller", "--help"], 60.0, venv, clean_env())
    assert "usage" in usage


def test_a_cell_starts_from_the_install_and_stops_on_sigterm(venv: Path) -> None:
    def command_on(port_base: int, router_port: int) -> list[str | Path]:
        return [
            *(venv / "bin" / "motocell", "up", "--config", "four-group", "--host", HOST),
            *("--port-base", str(port_base), "--zenoh-listen", f"tcp/{HOST}:{router_port}"),
        ]

    cell_starts_and_stops(command_on, venv, venv, HOST)
