"""``motocell plot`` on files that are not whole recordings: one clean line, whatever the size."""

from __future__ import annotations

import argparse
import io
from pathlib import Path

import pytest

from motocell.shared.bus.schemas import (
    GroupState,
    GroupTick,
    RobotStatusFields,
    State,
    Tick,
    encode,
)
from motocell.tools import plot
from motocell.tools.plotting import plot_recording
from motocell.tools.recording import McapSink, Recording


def plot_of(path: Path) -> int:
    parser = argparse.ArgumentParser()
    plot.add_arguments(parser)
    args = parser.parse_args([str(path)])
    status: int = args.run(args)
    return status


def recording() -> bytes:
    stream = io.BytesIO()
    sink = McapSink(stream)
    for n in range(20):
        tick = Tick(n, 0, 0, 0, True, [GroupTick([0] * 8, [0] * 8, [0] * 8, 0)])
        sink.write(1_000 + n, "motocell/c/executor/tick", encode(tick))
    sink.finish()
    return stream.getvalue()


@pytest.mark.parametrize("content", [b"", b"x", b"short", b"a text file, not a recording\n" * 40])
def test_a_file_that_is_not_mcap_gets_one_line_whatever_its_length(
    content: bytes, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "notes.mcap"
    path.write_bytes(content)
    assert plot_of(path) == 1
    out = capsys.readouterr()
    assert out.err == f"motocell plot: {path}: not an MCAP file (`motocell record` writes them)\n"
    assert not path.with_suffix(".png").exists()


CUT = "cut short, its recorder did not close it (killed, or a full disk)"


@pytest.mark.parametrize("keep", [8, 20, 100, 0.5, -10])
def test_a_cut_recording_without_states_gets_one_line_that_says_it_was_cut(
    keep: float, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    whole = recording()
    path = tmp_path / "cut.mcap"
    path.write_bytes(whole[: int(len(whole) * keep) if isinstance(keep, float) else keep])
    assert plot_of(path) == 1
    assert capsys.readouterr().err == (
        f"motocell plot: {path}: no state samples in the recording ({CUT})\n"
    )


def test_a_cut_recording_is_plotted_up_to_the_cut_and_says_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "cut.mcap"
    path.write_bytes(states_recording([2.5] * 6, flushed=True)[:-400])
    assert plot_of(path) == 0
    out = capsys.readouterr()
    assert out.err == f"motocell plot: {path}: {CUT}; plotted what it holds\n"
    assert out.out == f"wrote {path.with_suffix('.png')}\n"


def states_recording(command_velocities: list[float], *, flushed: bool = False) -> bytes:
    """A one-arm cell's state and ticks, its states with ``command_velocities`` (an older
    file's have none); ``flushed``: each sample in a chunk of its own, as
    the recorder's flushes leave them."""
    stream = io.BytesIO()
    sink = McapSink(stream)
    status = RobotStatusFields(1, 0, 0, 0, 1, 2, 1)
    for n in range(5):
        joints = [0.01 * n] * 6
        group = GroupState(0, joints, [2.5] * 6, joints, command_velocities=command_velocities)
        sink.write(1_000 + n, "motocell/c/state", encode(State(n + 1, n, 0, [group], status)))
        tick = Tick(n, 0, 0, 0, True, [GroupTick([0] * 8, [0] * 8, [0] * 8, 0)])
        sink.write(1_000 + n, "motocell/c/executor/tick", encode(tick))
        if flushed:
            sink.flush()
    sink.finish()
    return stream.getvalue()


@pytest.mark.parametrize(
    ("command_velocities", "title", "commanded_lines"),
    [
        ([2.5] * 6, "group 0: joint velocities, commanded (dashed) vs feedback (solid)", 6),
        ([], "group 0: joint velocities (feedback)", 0),
    ],
)
def test_the_velocity_panel_says_what_it_draws(
    tmp_path: Path, command_velocities: list[float], title: str, commanded_lines: int
) -> None:
    path = tmp_path / "run.mcap"
    path.write_bytes(states_recording(command_velocities))
    figure = plot_recording(Recording(path), tmp_path / "run.png")
    velocities = figure.axes[2]
    assert velocities.get_title() == title
    gids = [str(line.get_gid()) for line in velocities.get_lines()]
    assert sum(gid.endswith("/velocity/commanded") for gid in gids) == commanded_lines
    legend = velocities.get_legend()
    assert legend is not None
    labels = [text.get_text() for text in legend.get_texts()]
    assert ("commanded" in labels) == bool(commanded_lines)
