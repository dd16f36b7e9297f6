"""``motocell plot`` on files that are not whole recordings (one clean line, whatever the size),
what the velocity panel says it draws, and the tick panels' breaks where the clock rested."""

from __future__ import annotations

import argparse
import io
from pathlib import Path

import numpy as np
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
from motocell.tools.plotting import GAP_PERIODS, broken_at, plot_recording, tick_gaps
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


# -- the tick panels' lines break where the clock did not tick ----------------------------


@pytest.mark.parametrize(
    ("ticks", "gaps"),
    [
        ([], []),
        ([7], []),
        ([1, 2, 3, 4], []),
        ([1, 2, 4, 7], []),  # two ticks, then two, the recording lacks: still one line
        ([1, 2, 6, 7], [1]),  # the clock rested from tick 2 until tick 6
        ([1, 2, 2, 2, 300, 301], [1, 2, 3]),  # tick 2 resting, sent again twice, then a wake
        ([5, 3, 4], [0]),  # a restarted executor counts from its own start
    ],
)
def test_lines_break_after_a_tick_sent_again_or_more_than_gap_periods_on(
    ticks: list[int], gaps: list[int]
) -> None:
    assert GAP_PERIODS == 3
    assert tick_gaps(ticks).tolist() == gaps


def test_a_break_is_a_nan_after_each_gap() -> None:
    broken = broken_at(np.array([1, 3]), np.array([10, 11, 12, 13, 14]))
    np.testing.assert_array_equal(broken, [10, 11, np.nan, 12, 13, np.nan, 14])
    assert broken.dtype == np.float64
    np.testing.assert_array_equal(broken_at(np.array([], dtype=np.intp), np.arange(3)), [0, 1, 2])


def resting_recording() -> bytes:
    """Ticks 1 to 3 with the clock running, tick 3 the one it rests after, sent again a second
    later, and ticks 300 and 301 after it woke."""
    stream = io.BytesIO()
    sink = McapSink(stream)
    status = RobotStatusFields(1, 0, 0, 0, 0, 2, 1)
    group = GroupState(0, [0.0] * 6, [0.0] * 6, [0.0] * 6)
    sink.write(0, "motocell/c/state", encode(State(1, 1, 0, [group], status)))
    for n, log_ms, lateness_us in ((1, 4, 50), (2, 8, 60), (3, 12, 40), (3, 1012, 0)):
        tick = Tick(n, 0, lateness_us * 1000, 0, True, [GroupTick([0], [0], [0], 4 - n)])
        sink.write(log_ms * 1_000_000, "motocell/c/executor/tick", encode(tick))
    for n, log_ms in ((300, 1200), (301, 1204)):
        tick = Tick(n, 0, 1_600_000, 0, True, [GroupTick([0], [0], [0], 1)])
        sink.write(log_ms * 1_000_000, "motocell/c/executor/tick", encode(tick))
    sink.finish()
    return stream.getvalue()


def test_the_tick_panels_lift_the_pen_where_the_clock_rested(tmp_path: Path) -> None:
    path = tmp_path / "rest.mcap"
    path.write_bytes(resting_recording())
    figure = plot_recording(Recording(path), tmp_path / "rest.png")
    lines = {str(line.get_gid()): line for ax in figure.axes for line in ax.get_lines()}
    nan = np.nan
    lateness = lines["lateness"]
    np.testing.assert_array_equal(
        np.asarray(lateness.get_xdata()), [0.004, 0.008, 0.012, nan, 1.012, nan, 1.2, 1.204]
    )
    np.testing.assert_array_equal(
        np.asarray(lateness.get_ydata()), [50, 60, 40, nan, 0, nan, 1600, 1600]
    )
    np.testing.assert_array_equal(
        np.asarray(lines["group0/depth"].get_ydata()), [3, 2, 1, nan, 1, nan, 1, 1]
    )
