"""The two lanes of the suite: the fast one starts no process, ``cell`` tests may.

``pytest -m "not cell"`` is what a contributor runs on every save; it stays fast only while
nothing in it starts a process (a Python interpreter alone takes 20-50 ms to start, a cell
seconds), it fuzzes lightly (``hypothesis_profile``) and it keeps to its CPU budget
(``tests/budget.py``). Python raises an audit event (PEP 578) for every way it starts a
process, so an audit hook sees each one, also those that end before anyone could look in
/proc. A test outside the ``cell`` lane that starts one fails in the phase (set-up, call,
tear-down) that did it, naming what it started.

A Zenoh router opened in the test's own process is cheap, but some tests of one wait on it
for tenths of a second to seconds, which no CPU budget sees: a session refused over TLS
(Zenoh's failed handshake, then the probe that says why, up to ``refusal.PROBE_S``), a
command's timeout, a client rejoining its router. Those are marked ``cell`` too, each with what
it waits for.
"""

from __future__ import annotations

import sys
import threading
from collections.abc import Generator, Sequence
from typing import Any

import pytest

LANE = "cell"
"""The marker of the slow lane (pyproject.toml declares it)."""
FAST_LANE = f"not {LANE}"
"""The mark expression that selects the fast lane."""
FAST_FUZZING, DEEP_FUZZING = "fast", "deep"
"""The Hypothesis profiles (tests/conftest.py registers them): a few examples per property in
the fast lane, many in any other run."""
NARROWING_OPTIONS = ("keyword", "deselect", "ignore", "ignore_glob", "lf", "stepwise")
"""Options that run part of what the arguments select (-k, --deselect, --ignore,
--ignore-glob, --lf, --sw)."""
SPAWNS = frozenset(
    {"subprocess.Popen", "os.fork", "os.forkpty", "os.posix_spawn", "os.spawn", "os.system"}
)
"""The audit events of the Python calls that start a process (``pty.spawn`` forks through
``os.forkpty``, ``multiprocessing``'s fork method through ``os.fork``). Its spawn and
forkserver methods start theirs unaudited; nothing in motocell uses them."""


def is_fast_lane(markexpr: str) -> bool:
    """Whether ``-m markexpr`` selects the fast lane, however it is spaced."""
    return " ".join(markexpr.split()) == FAST_LANE


def hypothesis_profile(markexpr: str, chosen: str | None) -> str:
    """The profile a run fuzzes with: the one chosen with ``--hypothesis-profile``, else
    the light one in the fast lane and the deep one in any run that may include the cell lane
    (the whole suite, as ``scripts/check`` and CI run it, or a file on its own)."""
    if chosen:
        return chosen
    return FAST_FUZZING if is_fast_lane(markexpr) else DEEP_FUZZING


def runs_the_whole_fast_lane(config: pytest.Config) -> bool:
    """Whether this run is the fast lane, whole: ``-m "not cell"`` over the default paths,
    narrowed by nothing else, running its tests (not only collecting them)."""
    return (
        is_fast_lane(config.option.markexpr)
        and config.args_source is not pytest.Config.ArgsSource.ARGS
        and not any(config.getoption(name, None) for name in NARROWING_OPTIONS)
        and not config.option.collectonly
    )


class SpawnLog:
    """The processes started since the last ``take``, from any thread."""

    def __init__(self) -> None:
        self._seen: list[str] = []
        self._lock = threading.Lock()

    def audit(self, event: str, args: tuple[Any, ...]) -> None:
        if event in SPAWNS:
            with self._lock:
                self._seen.append(describe(event, args))

    def take(self) -> list[str]:
        """What was started since the last call, and forget it."""
        with self._lock:
            seen, self._seen = self._seen, []
        return seen


COMMAND_ARGUMENT = {"subprocess.Popen": 1, "os.posix_spawn": 1, "os.spawn": 2, "os.system": 0}
"""Where each event carries the command it starts (the others carry none)."""


def describe(event: str, args: tuple[Any, ...]) -> str:
    """``event`` with the command it starts, when the event carries one."""
    index = COMMAND_ARGUMENT.get(event)
    command = None if index is None else args[index]
    if isinstance(command, str | bytes):
        return f"{event}: {command!r}"
    if isinstance(command, Sequence):
        return f"{event}: {' '.join(map(str, command))}"
    return event


class SpawnGuard:
    """The plugin: fails each phase of a test outside the ``cell`` lane that starts a
    process. A phase that failed on its own is left to say why."""

    def __init__(self) -> None:
        self.log = SpawnLog()

    def pytest_configure(self, config: pytest.Config) -> None:
        # A hook cannot be removed: it stays for the interpreter's life, as this plugin does.
        sys.addaudithook(self.log.audit)

    @pytest.hookimpl(wrapper=True)
    def pytest_runtest_setup(self, item: pytest.Item) -> Generator[None, object, object]:
        return (yield from self._checked(item, "set-up"))

    @pytest.hookimpl(wrapper=True)
    def pytest_runtest_call(self, item: pytest.Item) -> Generator[None, object, object]:
        return (yield from self._checked(item, "the test"))

    @pytest.hookimpl(wrapper=True)
    def pytest_runtest_teardown(self, item: pytest.Item) -> Generator[None, object, object]:
        return (yield from self._checked(item, "tear-down"))

    def _checked(self, item: pytest.Item, phase: str) -> Generator[None, object, object]:
        self.log.take()
        result = yield
        started = self.log.take()
        if started and item.get_closest_marker(LANE) is None:
            pytest.fail(
                f"{phase} started {len(started)} process(es) outside the {LANE} lane (mark "
                f"the test pytest.mark.{LANE}, or start nothing): {'; '.join(started[:3])}",
                pytrace=False,
            )
        return result
