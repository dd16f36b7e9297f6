"""Running motocell from a venv it was installed into, apart from the development venv and the
source tree: tests/test_packaging.py (the sdist and the wheel), tests/testing/
test_installed_plugin.py (the wheel with pytest) and tests/e2e/test_image.py (the image's
files) use it. A pytest plugin of the suite (tests/conftest.py): ``artifacts`` is built once
per run for every test that installs one."""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from motocell.testing.ports import ended, on_free_port
from motocell.testing.processes import alive, cmdline, descendants, wait_until

ROOT = Path(__file__).resolve().parent.parent
PROJECT_FILES = ("pyproject.toml", "README.md", "LICENSE", "MANIFEST.in")
BUILD_TIMEOUT_S = 600.0
INSTALL_TIMEOUT_S = 900.0
"""Generous: on a loaded machine pip and the build's isolated environment take minutes."""
READY_TIMEOUT_S = 180.0
"""Generous: on a loaded machine a cell from a cold venv takes long to import and start."""
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


@pytest.fixture(scope="session")
def artifacts(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The sdist and the wheel built from it, by `python -m build`: once a run."""
    work = tmp_path_factory.mktemp("build")
    source = source_copy(work / "source")
    dist = work / "dist"
    run(
        [sys.executable, "-m", "build", "--outdir", dist, source],
        BUILD_TIMEOUT_S,
        work,
        clean_env(),
    )
    shutil.rmtree(source)
    (sdist,) = dist.glob("motocell-*.tar.gz")
    (wheel,) = dist.glob("motocell-*.whl")
    return {"sdist": sdist, "wheel": wheel}


def clean_env() -> dict[str, str]:
    """This process's environment without what points at the development venv or the tree."""
    env = {k: v for k, v in os.environ.items() if k not in {"PYTHONPATH", "VIRTUAL_ENV"}}
    return {**env, "PIP_NO_INPUT": "1", "PIP_DISABLE_PIP_VERSION_CHECK": "1"}


CommandOn = Callable[[int, int], list[str | Path]]
"""A launcher's command on a port base (its three TCP ports) and a port for its router."""


def cell_starts_and_stops(command_on: CommandOn, venv: Path, cwd: Path, host: str) -> None:
    """Run a launcher until its cell's ready line, on ports picked free (picked again when one
    was taken meanwhile), check that every process of the cell runs ``venv``'s Python, stop it
    with SIGTERM: it exits 0 and leaves nothing behind."""
    env = {**clean_env(), "MOTOCELL_RUNTIME_DIR": str(cwd / "runtime"), "MOTOCELL_LOG": "INFO"}
    log_path = cwd / "up.log"
    children: set[int] = set()

    def started(port_base: int) -> subprocess.Popen[bytes]:
        # Four ports in a row: motion, state, I/O, then the router's.
        command = [str(part) for part in command_on(port_base, port_base + 3)]
        with log_path.open("wb") as log:
            launcher = subprocess.Popen(command, cwd=cwd, env=env, stdout=log, stderr=log)
        try:
            wait_until(lambda: ready(launcher), READY_TIMEOUT_S, "the cell's ready line")
        except BaseException:
            stop(launcher, children)
            raise
        return launcher

    def ready(launcher: subprocess.Popen[bytes]) -> bool:
        children.update(descendants(launcher.pid))
        said = log_path.read_text(errors="replace")
        if launcher.poll() is not None:
            raise ended("the launcher", launcher.returncode, said)
        return re.search(r"cell \S+ ready: ", said) is not None

    try:
        launcher = on_free_port(started, count=4, host=host)
    except (AssertionError, TimeoutError) as error:
        raise AssertionError(f"{error}\n{log_path.read_text(errors='replace')}") from error
    try:
        pythons = {
            args[0] for pid in descendants(launcher.pid) | {launcher.pid} if (args := cmdline(pid))
        }
        assert pythons == {str(venv / "bin" / "python")}, pythons
    finally:
        stop(launcher, children)
    assert launcher.returncode == 0, log_path.read_text(errors="replace")
    assert not [pid for pid in children if alive(pid)], "services outlived the launcher"


def stop(launcher: subprocess.Popen[bytes], children: set[int]) -> None:
    """SIGTERM the launcher and wait for it and ``children``; kill what is left after that."""
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
