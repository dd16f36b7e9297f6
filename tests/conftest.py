"""Every test leaves no thread and no process of its own behind.

The check runs around each test and again around each module, so what a module-scoped fixture
(a module's cell) starts counts as "before" for the tests that use it, and must be gone once
the module's fixtures are torn down. A process that one of those started during a test (a
launcher restarting a service the test killed) is theirs too: only processes below this one
and not below anything that ran before count. Threads and processes get a short deadline to
finish (a listener closing, a cell stopping). A leaked process is killed before the test
fails, so later tests do not inherit it. Threads Python did not start (Zenoh's, which show up
as "dummy" threads once they run a callback) are not the test's.

Besides, a test outside the ``cell`` lane starts no process at all (``tests/lanes.py``), so
``pytest -m "not cell"`` stays fast; that lane fuzzes with the light Hypothesis profile, every
other run with the deep one, and the lane run whole keeps to a CPU budget
(``tests/budget.py``). A property's timeout counts CPU seconds, not wall seconds
(``tests/cpu_timeout.py``). A run starts by removing what earlier runs killed outright left outside
their process (``tests/leftovers.py``), and gives every test a registry of running cells of its
own instead of the user's.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import settings

from motocell.shared import registry
from motocell.shared.bus import ignored
from motocell.testing.processes import alive, children, descendants, wait_until
from tests import budget, cpu_timeout, lanes, leftovers

pytest_plugins = ["tests.routers", "tests.installed"]
"""The loopback router and its client sessions, for every test of a bus adapter; the built
sdist and wheel, for every test that installs one."""

DEADLINE_S = 5.0
_REGISTRY = pytest.StashKey[tuple[str, str | None]]()
"""This run's registry directory, and the value it replaced."""

# No deadline per example in either: the machines the suite runs on are shared and loaded, and a
# property holds or fails whatever an example's time (docs/conventions.md, "Lanes").
settings.register_profile(lanes.FAST_FUZZING, max_examples=20, deadline=None)
# 200, not 300: at 300 the property tests took about a minute of the whole suite's ten on the
# project's 2-core machine; this keeps the suite within its time.
settings.register_profile(lanes.DEEP_FUZZING, max_examples=200, deadline=None)


def _own_threads() -> set[threading.Thread]:
    return {
        thread
        for thread in threading.enumerate()
        if thread.is_alive() and not isinstance(thread, threading._DummyThread)
    }


def _own_processes() -> set[int]:
    return {pid for pid in descendants(os.getpid()) if alive(pid)}


def _started_since(before: set[int]) -> set[int]:
    """Running processes below this one, except what runs below a process of ``before``."""
    found: set[int] = set()
    frontier = [os.getpid()]
    while frontier:
        for child in children(frontier.pop()) - before - found:
            if alive(child):
                found.add(child)
                frontier.append(child)
    return found


def _leaks(threads: set[threading.Thread], processes: set[int]) -> list[str]:
    """What is still running that was not running before, after the deadline."""

    def new_threads() -> set[threading.Thread]:
        return _own_threads() - threads

    try:
        wait_until(
            lambda: not new_threads() and not _started_since(processes), DEADLINE_S, "leftovers"
        )
    except TimeoutError:
        leaked = _started_since(processes)
        for pid in leaked:
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
        return [
            *(f"thread {thread.name!r} ({thread.ident})" for thread in new_threads()),
            *(f"process {pid}" for pid in sorted(leaked)),
        ]
    return []


def _check(what: str) -> Iterator[None]:
    threads, processes = _own_threads(), _own_processes()
    yield
    leaks = _leaks(threads, processes)
    if leaks:
        pytest.fail(f"{what} left running after {DEADLINE_S} s: {', '.join(leaks)}")


@pytest.fixture(autouse=True, scope="module")
def no_leaks_per_module() -> Iterator[None]:
    """Autouse fixtures come first in their scope, so this one is torn down after every other
    module-scoped fixture: it sees what those left behind."""
    yield from _check("the module's fixtures")


@pytest.fixture(autouse=True)
def no_leaks() -> Iterator[None]:
    yield from _check("the test")


@pytest.fixture(autouse=True)
def fresh_ignored_samples(monkeypatch: pytest.MonkeyPatch) -> None:
    """Each test its own tally of ignored samples: what an earlier test ignored must not
    keep this one's first ignored sample out of the log."""
    monkeypatch.setattr(ignored, "IGNORED", ignored.IgnoredSamples())


def pytest_configure(config: pytest.Config) -> None:
    config.pluginmanager.register(lanes.SpawnGuard(), "spawn-guard")
    config.pluginmanager.register(budget.CpuBudget(), "cpu-budget")
    config.pluginmanager.register(cpu_timeout.CpuTimeout(), "cpu-timeout")
    settings.load_profile(
        lanes.hypothesis_profile(
            config.option.markexpr, config.getoption("hypothesis_profile", None)
        )
    )


def pytest_sessionstart(session: pytest.Session) -> None:
    """Remove what earlier runs left (tests/leftovers.py), one line each; then give this run
    a registry of its own, so no test, nor a process one starts, touches the user's."""
    reporter = session.config.pluginmanager.get_plugin("terminalreporter")
    for line in leftovers.clean():
        if reporter is not None:
            reporter.write_line(f"removed what an earlier test run left: {line}")
    directory = tempfile.mkdtemp(prefix=f"motocell-tests-{os.getpid()}-")
    session.config.stash[_REGISTRY] = (directory, os.environ.get(registry.ENV))
    os.environ[registry.ENV] = directory


def pytest_sessionfinish(session: pytest.Session) -> None:
    if _REGISTRY not in session.config.stash:
        return  # the session did not start
    directory, before = session.config.stash[_REGISTRY]
    shutil.rmtree(directory, ignore_errors=True)
    if before is None:
        os.environ.pop(registry.ENV, None)
    else:
        os.environ[registry.ENV] = before


@pytest.fixture
def dead_pid() -> int:
    """A pid no process has: pids stay below the kernel's pid_max. Cheaper than starting a
    process to see it gone, which would put the test in the slow lane."""
    return int(Path("/proc/sys/kernel/pid_max").read_text())
