"""The sdist and the wheel hold what a cell needs: each is built, installed into a fresh venv,
and a cell is started from it.

The sdist is built from a copy of the source tree (the tree itself is left alone) and the wheel
from that sdist, as `python -m build` does, so a file the sdist lacks fails the wheel too. Each
venv gets the artifact and its declared dependencies the way `scripts/setup` gets them (pip,
with this machine's configuration), and runs with the venv's own Python from a directory
outside the source tree, so nothing of the checkout can stand in for the installed package.
The layout these artifacts come from: ARCHITECTURE.md, Code layout."""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import signal
import subprocess
import sys
import tarfile
import time
import zipfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from motocell.shared.ports import free_port, free_port_block
from motocell.testkit.processes import alive, cmdline, descendants, wait_until

pytestmark = [pytest.mark.cell, pytest.mark.timeout(1800)]

ROOT = Path(__file__).resolve().parent.parent
PROJECT_FILES = ("pyproject.toml", "README.md", "LICENSE", "MANIFEST.in")
HOST = "127.0.0.1"
BUILD_TIMEOUT_S = 600.0
INSTALL_TIMEOUT_S = 900.0
"""Generous: on a loaded machine pip and the build's isolated environment take minutes."""
READY_TIMEOUT_S = 180.0
STOP_TIMEOUT_S = 30.0


def run(command: list[str | Path], timeout: float, cwd: Path, env: dict[str, str]) -> str:
    """Run ``command`` to completion; its output, or AssertionError with that output."""
    done = subprocess.run(
        [str(part) for part in command],
        cwd=cwd,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        timeout=timeout,
        check=False,
    )
    assert done.returncode == 0, f"{command} exited with {done.returncode}:\n{done.stdout}"
    return done.stdout


def clean_env() -> dict[str, str]:
    """This process's environment without what points at the development venv or the tree."""
    env = {k: v for k, v in os.environ.items() if k not in {"PYTHONPATH", "VIRTUAL_ENV"}}
    return {**env, "PIP_NO_INPUT": "1", "PIP_DISABLE_PIP_VERSION_CHECK": "1"}


def source_copy(destination: Path) -> Path:
    """What a build needs of the source tree: the project files, `motocell/` with its links,
    and the folders they point to, without caches or results."""
    destination.mkdir()
    for name in PROJECT_FILES:
        shutil.copy2(ROOT / name, destination / name)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "results")
    shutil.copytree(ROOT / "motocell", destination / "motocell", symlinks=True, ignore=ignore)
    for link in (ROOT / "motocell").iterdir():
        if link.is_symlink():
            target = link.resolve()
            shutil.copytree(target, destination / target.name, ignore=ignore)
    return destination


@pytest.fixture(scope="module")
def artifacts(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The sdist and the wheel built from it, by `python -m build`."""
    work = tmp_path_factory.mktemp("build")
    source = source_copy(work / "source")
    dist = work / "dist"
    run(
        [sys.executable, "-m", "build", "--outdir", dist, source],
        BUILD_TIMEOUT_S,
        work,
        clean_env(),
    )
    (sdist,) = dist.glob("motocell-*.tar.gz")
    (wheel,) = dist.glob("motocell-*.whl")
    return {"sdist": sdist, "wheel": wheel}


def test_the_sdist_holds_the_package_and_no_tests(artifacts: dict[str, Path]) -> None:
    with tarfile.open(artifacts["sdist"]) as sdist:
        names = {name.split("/", 1)[1] for name in sdist.getnames() if "/" in name}
    assert {*PROJECT_FILES, "motocell/__init__.py", "motocell/shared/models.toml"} <= names
    assert "motocell/services/gateway/__main__.py" in names
    assert not [name for name in names if name.startswith("tests")], "tests in the sdist"
    assert not [name for name in names if "__pycache__" in name]


def test_the_wheel_holds_one_package_and_the_license(artifacts: dict[str, Path]) -> None:
    with zipfile.ZipFile(artifacts["wheel"]) as wheel:
        names = wheel.namelist()
    tops = {name.split("/", 1)[0] for name in names}
    assert {top for top in tops if not top.endswith(".dist-info")} == {"motocell"}
    assert any(re.search(r"\.dist-info/licenses/LICENSE$", name) for name in names)
    assert "motocell/shared/cells/four-group.toml" in names


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
    port_base = free_port_block(3, HOST)
    router_port = free_port(HOST)
    while port_base <= router_port < port_base + 3:
        router_port = free_port(HOST)
    env = {**clean_env(), "MOTOCELL_RUNTIME_DIR": str(venv / "runtime"), "MOTOCELL_LOG": "INFO"}
    log_path = venv / "up.log"
    command = [
        venv / "bin" / "motocell",
        "up",
        "--config",
        "four-group",
        "--host",
        HOST,
        "--port-base",
        str(port_base),
        "--zenoh-listen",
        f"tcp/{HOST}:{router_port}",
    ]
    with log_path.open("wb") as log:
        launcher = subprocess.Popen(
            [str(part) for part in command], cwd=venv, env=env, stdout=log, stderr=log
        )
    children: set[int] = set()

    def ready() -> bool:
        children.update(descendants(launcher.pid))
        if launcher.poll() is not None:
            raise AssertionError(f"motocell up exited with {launcher.returncode}")
        return re.search(r"cell \S+ ready: ", log_path.read_text(errors="replace")) is not None

    try:
        wait_until(ready, READY_TIMEOUT_S, "the cell's ready line")
        pythons = {
            args[0] for pid in descendants(launcher.pid) | {launcher.pid} if (args := cmdline(pid))
        }
        assert pythons == {str(venv / "bin" / "python")}, pythons
    except (AssertionError, TimeoutError) as error:
        raise AssertionError(f"{error}\n{log_path.read_text(errors='replace')}") from error
    finally:
        if launcher.poll() is None:
            launcher.send_signal(signal.SIGTERM)
        try:
            launcher.wait(timeout=STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            launcher.kill()
            launcher.wait()
        deadline = time.monotonic() + STOP_TIMEOUT_S
        while any(alive(pid) for pid in children) and time.monotonic() < deadline:
            time.sleep(0.1)
        for pid in children:
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
    assert launcher.returncode == 0, log_path.read_text(errors="replace")
    assert not [pid for pid in children if alive(pid)], "services outlived the launcher"
