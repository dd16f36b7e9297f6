"""A failed test's report on its cells and ``--motocell-keep-failed``, through the plugin's
own hooks in a pytest run in this process (``pytester``), with cells that are fakes: a section
per cell of a failed test only, a cell that cannot be read named in one line with the test's
own failure kept, and the kept cells stopped after the run instead of at their scope's end."""

from __future__ import annotations

import textwrap
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager

import pytest

from motocell import testing
from motocell.testing.fixtures import Keeper, cell_fixture
from motocell.testing.report import Reported, Starts, reported_in, section

pytest_plugins = ["pytester"]

CONFTEST = """
import contextlib
from pathlib import Path

import pytest

from motocell.testing.fixtures import kept_if_failed
from motocell.testing.report import Reported

EVENTS = Path("events.txt")


class FakeCell(Reported):
    def __init__(self, name, answers):
        self._name, self.answers = name, answers

    @property
    def name(self):
        return self._name

    def described(self):
        if not self.answers:
            raise TimeoutError("timed out after 2.0 s waiting for a controller status")
        return ["E-stop on, HOLD off"]

    def how_to_look(self):
        return [f"  motocell watch --cell {self._name}"]


@contextlib.contextmanager
def fake(name, answers=True):
    yield FakeCell(name, answers)
    with EVENTS.open("a") as events:
        events.write(f"{name} stopped\\n")


@pytest.fixture
def cell(request):
    yield from kept_if_failed(request, fake(request.node.name))


@pytest.fixture
def silent_cell(request):
    yield from kept_if_failed(request, fake("silent", answers=False))


def pytest_sessionfinish():
    with EVENTS.open("a") as events:
        events.write("session finished\\n")
"""

TESTS = """
def test_passes(cell):
    pass


def test_fails(cell):
    assert False, "the test's own failure"


def test_fails_with_a_cell_that_does_not_answer(silent_cell):
    assert False, "the test's own failure"
"""


def run(pytester: pytest.Pytester, *options: str) -> tuple[pytest.HookRecorder, list[str]]:
    pytester.makeconftest(textwrap.dedent(CONFTEST))
    pytester.makepyfile(test_user=textwrap.dedent(TESTS))
    result = pytester.inline_run("-p", "no:cacheprovider", *options)
    result.assertoutcome(passed=1, failed=2)
    return result, (pytester.path / "events.txt").read_text().splitlines()


def sections_of(result: pytest.HookRecorder) -> dict[str, list[tuple[str, str]]]:
    return {
        report.nodeid.split("::")[-1]: [s for s in report.sections if s[0].startswith("motocell")]
        for report in result.getreports("pytest_runtest_logreport")
        if report.when == "call"
    }


def test_a_failed_test_has_a_section_per_cell_and_its_cells_stop_with_their_scope(
    pytester: pytest.Pytester,
) -> None:
    result, events = run(pytester)
    assert sections_of(result) == {
        "test_passes": [],
        "test_fails": [("motocell cell test_fails", "E-stop on, HOLD off")],
        "test_fails_with_a_cell_that_does_not_answer": [
            (
                "motocell cell silent",
                "the cell could not be read: TimeoutError: timed out after 2.0 s waiting for a"
                " controller status",
            )
        ],
    }
    (silent,) = [r for r in result.getfailures() if "not_answer" in r.nodeid]
    assert "the test's own failure" in silent.longreprtext
    assert events == [
        "test_passes stopped",
        "test_fails stopped",
        "silent stopped",
        "session finished",
    ]


def test_kept_cells_say_how_to_look_and_stop_after_the_run(pytester: pytest.Pytester) -> None:
    result, events = run(pytester, "--motocell-keep-failed")
    ((_, text),) = sections_of(result)["test_fails"]
    assert text.startswith("E-stop on, HOLD off\n\nkept running (--motocell-keep-failed) until")
    assert text.endswith(":\n  motocell watch --cell test_fails")
    assert sections_of(result)["test_passes"] == []
    assert events == [
        "test_passes stopped",
        "session finished",
        "silent stopped",
        "test_fails stopped",
    ]


class Cell(Reported):
    def __init__(self, name: str) -> None:
        self._name = name

    @property
    def name(self) -> str:
        return self._name

    def described(self) -> list[str]:
        return ["servo off"]

    def how_to_look(self) -> list[str]:
        raise AssertionError("a cell that joined an open router has no credentials")


class Cells(Starts):
    @property
    def started(self) -> tuple[Cell, ...]:
        return (Cell("a"), Cell("b"))


def test_the_cells_of_a_fixture_are_the_cell_or_those_it_started() -> None:
    assert [cell.name for cell in reported_in(Cells())] == ["a", "b"]
    assert reported_in(object()) == []


def test_commands_that_cannot_be_said_are_one_line_after_the_cells_state() -> None:
    _, text = section(Cell("a"), kept=True)
    assert text.splitlines()[0] == "servo off"
    assert text.splitlines()[-1] == (
        "the cell could not be read: AssertionError: a cell that joined an open router has no"
        " credentials"
    )


def test_a_person_is_asked_before_kept_cells_stop_and_not_without_any() -> None:
    asked: list[tuple[str, list[str]]] = []
    stopped: list[str] = []
    Keeper(keep=True).stop(lambda prompt: asked.append((prompt, list(stopped))))
    assert asked == []
    keeper, cell = Keeper(keep=True), Cell("a")
    assert keeper.failed_with(cell)
    with ExitStack() as stop:
        stop.callback(stopped.append, "a")
        keeper.hand_over(cell, stop)
    assert stopped == []
    keeper.stop(lambda prompt: asked.append((prompt, list(stopped))))
    assert asked == [("motocell: a kept running; Enter stops them ", [])]
    assert stopped == ["a"]


def test_a_scope_pytest_does_not_have_is_refused_in_one_line() -> None:
    with pytest.raises(ValueError, match=r"^cell_fixture: scope 'modul' is not one of: function"):
        cell_fixture(scope="modul")  # type: ignore[arg-type]


def test_motocell_testing_names_each_of_its_names_home() -> None:
    assert sorted(testing.__all__) == sorted(testing.HOMES)
    for name in testing.__all__:
        assert getattr(testing, name).__name__ == name


FACTORY_CONFTEST = """
from motocell.testing import cell_fixture

per_module = cell_fixture("four-group", scope="module", byte_order="big")
"""

FACTORY_TESTS = """
def test_one(per_module):
    assert per_module == ("four-group", {"byte_order": "big"})


def test_two(per_module):
    pass
"""


def test_a_factory_cell_at_module_scope_is_one_cell_per_module_also_without_the_plugin(
    pytester: pytest.Pytester, monkeypatch: pytest.MonkeyPatch
) -> None:
    started: list[str] = []

    @contextmanager
    def cell(config: str, *, name: None, **settings: object) -> Iterator[tuple[str, object]]:
        started.append(config)
        yield config, settings

    monkeypatch.setattr(testing, "cell", cell, raising=False)
    pytester.makeconftest(textwrap.dedent(FACTORY_CONFTEST))
    tests = textwrap.dedent(FACTORY_TESTS)
    pytester.makepyfile(test_first=tests, test_second=tests)
    pytester.inline_run("-p", "no:cacheprovider").assertoutcome(passed=4)
    assert started == ["four-group", "four-group"]
    pytester.inline_run("-p", "no:cacheprovider", "-p", "no:motocell").assertoutcome(passed=4)
    assert len(started) == 4
    shown = pytester.runpytest_inprocess("-p", "no:cacheprovider", "--fixtures")
    shown.stdout.fnmatch_lines(
        ["per_module [[]module scope[]]*", "*A started cell four-group, byte_order='big', shared*"]
    )
