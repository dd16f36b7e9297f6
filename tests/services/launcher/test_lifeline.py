"""The launcher's lifeline (``--lifeline FD``) on real pipes: the end of the starter's write end
stops the cell and removes the scratch directories; a stop for another reason removes nothing;
a descriptor that is no pipe is one line, exit status 2, before anything starts."""

from __future__ import annotations

import argparse
import os
from collections.abc import Iterator
from pathlib import Path

import pytest

from motocell.services.launcher.cli import add_arguments
from motocell.services.launcher.lifeline import LifelineError, check_lifeline, lifeline
from motocell.services.launcher.up import run
from motocell.shared.config import EXIT_CONFIG
from motocell.shared.service import StopFlag

WAIT_S = 10.0
"""For the watcher to see the end of file: at once; a bound for a hang."""


@pytest.fixture
def pipe() -> Iterator[tuple[int, int]]:
    """A pipe's (read, write) ends; whichever the test has not closed is closed after it."""
    read, write = os.pipe()
    yield read, write
    for fd in (read, write):
        try:
            os.close(fd)
        except OSError:
            continue


@pytest.fixture
def scratch(tmp_path: Path) -> list[str]:
    made = tmp_path / "run"
    (made / "credentials" / "cell").mkdir(parents=True)
    (made / "credentials" / "cell" / "passwords").write_text("secret")
    cell_file = tmp_path / "cell.toml"
    cell_file.write_text("")
    return [str(made), str(cell_file), str(tmp_path / "never-made")]


def test_the_end_of_the_starters_write_end_stops_and_removes_the_scratch(
    pipe: tuple[int, int], scratch: list[str]
) -> None:
    read, write = pipe
    stop = StopFlag()
    with lifeline(read, scratch, stop):
        os.write(write, b"anything")  # what the starter writes is no stop
        assert not stop.wait(0.05)
        os.close(write)
        assert stop.wait(WAIT_S)
        assert all(map(os.path.exists, scratch[:2]))  # not while the cell still stops
    assert not any(map(os.path.exists, scratch))


def test_a_stop_for_another_reason_leaves_the_scratch_to_the_starter(
    pipe: tuple[int, int], scratch: list[str]
) -> None:
    read, write = pipe
    stop = StopFlag()
    with lifeline(read, scratch, stop):
        stop.set()  # SIGTERM
    os.close(write)  # the starter, once the launcher is gone: its watcher ends too
    assert all(map(os.path.exists, scratch[:2]))


def test_without_a_lifeline_nothing_is_watched_or_removed(scratch: list[str]) -> None:
    stop = StopFlag()
    with lifeline(None, [], stop):
        pass
    assert not stop.is_set()
    assert all(map(os.path.exists, scratch[:2]))


def test_only_a_pipe_held_open_is_a_lifeline(pipe: tuple[int, int], tmp_path: Path) -> None:
    read, _ = pipe
    check_lifeline(read, [str(tmp_path)])
    assert not os.get_inheritable(read)  # the services do not hold it
    with (tmp_path / "file").open("w") as file, pytest.raises(LifelineError) as refused:
        check_lifeline(fd := file.fileno(), [])
    assert str(refused.value) == f"--lifeline {fd}: descriptor {fd} is not a pipe"
    with pytest.raises(LifelineError, match="--lifeline-scratch needs --lifeline"):
        check_lifeline(None, [str(tmp_path)])


def test_motocell_up_refuses_a_descriptor_it_does_not_hold_in_one_line(
    pipe: tuple[int, int], capsys: pytest.CaptureFixture[str]
) -> None:
    read, write = pipe
    os.close(read)
    os.close(write)  # both numbers now name nothing in this process
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    assert run(parser.parse_args(["--lifeline", str(read)])) == EXIT_CONFIG
    assert capsys.readouterr().err == (
        f"motocell up: --lifeline {read}: this process has no descriptor {read} (start it "
        "with the read end of a pipe as that descriptor)\n"
    )


def test_a_descriptor_is_a_number(capsys: pytest.CaptureFixture[str]) -> None:
    parser = argparse.ArgumentParser(prog="motocell up")
    add_arguments(parser)
    with pytest.raises(SystemExit) as exited:
        parser.parse_args(["--lifeline", "-1"])
    assert exited.value.code == EXIT_CONFIG
    assert capsys.readouterr().err.splitlines()[-1] == (
        "motocell up: error: argument --lifeline: '-1' is not a descriptor number"
    )
