"""``motocell plot`` on files that are not whole recordings: one clean line, whatever the size."""

from __future__ import annotations

import argparse
import io
from pathlib import Path

import pytest

from motocell.shared.bus.schemas import GroupTick, Tick, encode
from motocell.tools import plot
from motocell.tools.recording import McapSink


def plot_of(path: Path) -> int:
    parser = argparse.ArgumentParser()
    plot.add_parser(parser.add_subparsers())
    args = parser.parse_args(["plot", str(path)])
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


@pytest.mark.parametrize("keep", [8, 20, 100, 0.5, -10])
def test_a_recording_cut_short_gets_one_line(
    keep: float, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    whole = recording()
    path = tmp_path / "cut.mcap"
    path.write_bytes(whole[: int(len(whole) * keep) if isinstance(keep, float) else keep])
    assert plot_of(path) == 1
    assert capsys.readouterr().err == f"motocell plot: {path}: an MCAP file cut short or damaged\n"
