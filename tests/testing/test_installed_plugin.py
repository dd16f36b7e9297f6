"""A user's own tests, run as a user runs them: motocell built into a wheel and installed with
pytest into a fresh venv, the test files in a directory outside the repository, ``python -m
pytest`` there. The plugin comes from the installed entry point alone; every cell it started
is gone afterwards, after a test that fails on purpose, after Ctrl-C, and after pytest is
killed outright (SIGKILL, SIGTERM) too.

The build and the install are tests/test_packaging.py's (a copy of the source tree, pip with
this machine's configuration). The user's files are ``tests/testing/user``'s, typed and
checked with the project's code."""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import signal
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from motocell.testing.processes import cmdline, wait_until
from tests.installed import INSTALL_TIMEOUT_S, clean_env, run
from tests.terminal import as_a_terminal_starts

pytestmark = [pytest.mark.cell, pytest.mark.timeout(1800)]

USER_FILES = Path(__file__).parent / "user"
RUN_TIMEOUT_S = 300.0
"""For a user's run of three tests and four cells; generous for a loaded machine, where a
cold venv also compiles what it imports first."""
READY_TIMEOUT_S = 180.0
EXIT_TIMEOUT_S = 60.0
GONE_TIMEOUT_S = 15.0
"""For a cell to be gone once the run that started it is: its launcher stops it within 5 s."""


@pytest.fixture(scope="module")
def venv(tmp_path_factory: pytest.TempPathFactory, artifacts: dict[str, Path]) -> Iterator[Path]:
    """A fresh venv with motocell's wheel and pytest, nothing else of ours."""
    work = tmp_path_factory.mktemp("plugin")
    home = work / "venv"
    run([sys.executable, "-m", "venv", home], INSTALL_TIMEOUT_S, work, clean_env())
    pip: list[str | Path] = [home / "bin" / "python", "-m", "pip", "install", "--quiet"]
    run([*pip, artifacts["wheel"], "pytest"], INSTALL_TIMEOUT_S, work, clean_env())
    yield home
    shutil.rmtree(work, ignore_errors=True)


@pytest.fixture
def project(tmp_path: Path) -> Path:
    """The user's project: a directory of test files, and a TMPDIR of its own, where each
    cell keeps its registry, credentials and cell file while it runs."""
    (tmp_path / "tmp").mkdir()
    shutil.copy(USER_FILES / "client.py", tmp_path / "test_client.py")
    shutil.copy(USER_FILES / "interrupted.py", tmp_path / "test_interrupted.py")
    return tmp_path


def user_env(project: Path) -> dict[str, str]:
    """Faulthandler on: a run that outlives its deadline is aborted with every thread's stack
    in its output (``exit_of``)."""
    return {
        **clean_env(),
        "TMPDIR": str(project / "tmp"),
        "READY_FILE": str(project / "ready"),
        "PYTHONFAULTHANDLER": "1",
    }


def pytest_command(venv: Path, test_file: str) -> list[str]:
    return [str(venv / "bin" / "python"), "-m", "pytest", "-p", "no:cacheprovider", test_file]


def processes_of(venv: Path) -> list[str]:
    """Every running process of the venv's Python: a cell the plugin started runs only those."""
    pids = (int(entry.name) for entry in Path("/proc").iterdir() if entry.name.isdigit())
    argvs = ((pid, cmdline(pid)) for pid in pids)
    return [
        f"{pid}: {' '.join(argv)}"
        for pid, argv in argvs
        if argv[:1] and argv[0].startswith(str(venv))
    ]


def assert_nothing_left(venv: Path, project: Path, output: str) -> None:
    assert processes_of(venv) == [], output
    assert list((project / "tmp").iterdir()) == [], output


def test_a_passing_and_a_failing_test_leave_no_cell_behind(venv: Path, project: Path) -> None:
    done = subprocess.run(
        pytest_command(venv, "test_client.py"),
        cwd=project,
        env=user_env(project),
        capture_output=True,
        text=True,
        timeout=RUN_TIMEOUT_S,
        check=False,
    )
    output = done.stdout + done.stderr
    assert done.returncode == 1, output
    assert re.search(r"\b1 failed, 3 passed\b", output), output
    assert "FAILED test_client.py::test_trajectory_mode_under_an_estop_fails_on_purpose" in output
    assert "fails on purpose: the E-stop is on" in output
    assert re.search(r"- motocell cell test-\d+-\d+ -+\nservo .*\nE-stop on, HOLD off\n", output)
    assert_nothing_left(venv, project, output)


@contextmanager
def interrupted_run(venv: Path, project: Path) -> Iterator[subprocess.Popen[bytes]]:
    """``test_interrupted.py`` run by pytest in a session of its own, once its test runs
    with its cell; killed (its whole session) on exit if it still runs."""
    with (project / "pytest.log").open("w") as out:
        user = subprocess.Popen(
            as_a_terminal_starts(pytest_command(venv, "test_interrupted.py")),
            cwd=project,
            env=user_env(project),
            stdout=out,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
    try:
        wait_until(
            lambda: (project / "ready").exists() or user.poll() is not None,
            READY_TIMEOUT_S,
            "the test to run",
        )
        assert user.poll() is None, output_of(project)
        # The cell runs the venv's Python: what is left of it afterwards cannot hide.
        assert len(processes_of(venv)) > len(("pytest", "launcher", "services")), output_of(project)
        yield user
    finally:
        if user.poll() is None:
            os.killpg(user.pid, signal.SIGKILL)
            user.wait()


def output_of(project: Path) -> str:
    return (project / "pytest.log").read_text()


def exit_of(user: subprocess.Popen[bytes], project: Path) -> int:
    """The user's pytest's exit status within EXIT_TIMEOUT_S. AssertionError with its output
    otherwise, where faulthandler wrote each thread's stack when it was aborted (SIGABRT)."""
    try:
        return user.wait(EXIT_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        user.send_signal(signal.SIGABRT)
        with contextlib.suppress(subprocess.TimeoutExpired):
            user.wait(EXIT_TIMEOUT_S)
        raise AssertionError(
            f"still running {EXIT_TIMEOUT_S:.0f} s later; its stacks when aborted:\n"
            + output_of(project)
        ) from None


def test_ctrl_c_stops_the_cell_of_the_test_it_interrupts(venv: Path, project: Path) -> None:
    with interrupted_run(venv, project) as user:
        os.killpg(user.pid, signal.SIGINT)  # what Ctrl-C at a terminal sends
        assert exit_of(user, project) == pytest.ExitCode.INTERRUPTED, output_of(project)
    output = output_of(project)
    assert "KeyboardInterrupt" in output, output
    assert_nothing_left(venv, project, output)


@pytest.mark.parametrize("how", [signal.SIGKILL, signal.SIGTERM], ids=["SIGKILL", "SIGTERM"])
def test_a_run_killed_outright_leaves_no_cell_behind(
    venv: Path, project: Path, how: signal.Signals
) -> None:
    """Only pytest's process is signalled, as the OOM killer or ``kill PID`` does: it tears
    nothing down, and the cell goes by itself."""
    with interrupted_run(venv, project) as user:
        user.send_signal(how)
        assert exit_of(user, project) == -how
    with contextlib.suppress(TimeoutError):  # the assertion below says what is left
        wait_until(
            lambda: not processes_of(venv) and not any((project / "tmp").iterdir()),
            GONE_TIMEOUT_S,
            "the cell to be gone",
        )
    assert_nothing_left(venv, project, output_of(project))
