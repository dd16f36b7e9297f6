"""Reading a recording back whole or cut: a recorder killed mid-write leaves a file without
its summary, possibly ending mid-record; what was flushed before the cut is read, and the
reading says the file was cut."""

from __future__ import annotations

import io
from pathlib import Path

import pytest

from motocell.shared.bus.schemas import GroupTick, Tick, encode
from motocell.tools.recording import McapSink, NotARecordingError, Recording

KEY = "motocell/c/executor/tick"
TICKS = 6


def flushed_recording() -> bytes:
    """Ticks 0..TICKS-1, each flushed into a chunk of its own, as the recorder's flushes
    leave them, then the summary."""
    stream = io.BytesIO()
    sink = McapSink(stream)
    for n in range(TICKS):
        sink.write(1_000 + n, KEY, encode(Tick(n, 0, 0, 0, True, [GroupTick([0], [0], [0], 0)])))
        sink.flush()
    sink.finish()
    return stream.getvalue()


def ticks_in(path: Path) -> tuple[list[int], bool]:
    recording = Recording(path)
    return [payload["tick"] for _, _, payload in recording.messages()], recording.cut


def test_a_whole_recording_is_read_whole_and_not_cut(tmp_path: Path) -> None:
    path = tmp_path / "whole.mcap"
    path.write_bytes(flushed_recording())
    assert ticks_in(path) == (list(range(TICKS)), False)


def test_a_recording_cut_anywhere_gives_what_precedes_the_cut_and_says_it_was_cut(
    tmp_path: Path,
) -> None:
    whole = flushed_recording()
    path = tmp_path / "cut.mcap"
    seen = set()
    for length in range(8, len(whole)):  # past the opening magic: every cut a kill can make
        path.write_bytes(whole[:length])
        ticks, cut = ticks_in(path)
        assert cut, length
        assert ticks == list(range(len(ticks))), length  # a prefix, in order
        seen.add(len(ticks))
    # Each flushed chunk is readable as soon as it is whole: every prefix occurs.
    assert seen == set(range(TICKS + 1))


@pytest.mark.parametrize("content", [b"", b"MCAP", b"a text file\n" * 10])
def test_a_file_that_is_not_mcap_is_said_so(tmp_path: Path, content: bytes) -> None:
    path = tmp_path / "notes.mcap"
    path.write_bytes(content)
    with pytest.raises(NotARecordingError, match="not an MCAP file"):
        list(Recording(path).messages())
