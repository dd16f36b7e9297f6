"""Reading a recording back whole or cut: a recorder killed mid-write leaves a file without
its summary, possibly ending mid-record; what was flushed before the cut is read, and the
reading says the file was cut. Repaired, it gets the summary indexed readers need."""

from __future__ import annotations

import io
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.records import Channel, Message

from motocell.shared.bus.schemas import GroupTick, Tick, encode
from motocell.tools import cli
from motocell.tools.recording import McapSink, NotARecordingError, Recording, repair

KEY = "motocell/c/executor/tick"
TICKS = 6


def flushed_recording() -> bytes:
    """Ticks 0..TICKS-1, each flushed into a chunk of its own, as the recorder's flushes
    leave them, then the summary."""
    stream = io.BytesIO()
    sink = McapSink(stream)
    sink.metadata("motocell.recording", {"key_exprs": "motocell/c/**"})
    sink.flush()
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


def messages_of_a_whole_file(path: Path) -> list[tuple[str, int, bytes]]:
    """Read the way Foxglove reads: through the summary, which a cut file lacks."""
    with path.open("rb") as file:
        reader = make_reader(file, validate_crcs=True)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        messages = [(c.topic, m.log_time, m.data) for _, c, m in reader.iter_messages()]
        assert summary.statistics.message_count == len(messages)
    return messages


def messages_before_the_cut(path: Path) -> list[tuple[str, int, bytes]]:
    topics: dict[int, str] = {}
    messages = []
    for record in Recording(path).records():
        if isinstance(record, Channel):
            topics[record.id] = record.topic
        elif isinstance(record, Message):
            messages.append((topics[record.channel_id], record.log_time, record.data))
    return messages


def test_a_repaired_cut_opens_in_the_indexed_reader_with_all_it_held(tmp_path: Path) -> None:
    whole = flushed_recording()
    path, repaired = tmp_path / "cut.mcap", tmp_path / "repaired.mcap"
    for length in range(8, len(whole) + 1, 7):  # cuts of every kind, and the whole file
        path.write_bytes(whole[:length])
        held, _ = ticks_in(path)
        with repaired.open("wb") as out:
            copied = repair(Recording(path), out)
        # The keys' messages and the view's, as they were.
        assert messages_of_a_whole_file(repaired) == messages_before_the_cut(path), length
        assert copied == len(messages_before_the_cut(path)), length
        assert ticks_in(repaired) == (held, False)


def motocell(*argv: str) -> int:
    """The command's exit status, run here as ``motocell`` runs it."""
    args = cli.build_parser().parse_args(argv)
    return int(args.run(args))


def test_record_repair_writes_a_new_file_and_refuses_mistakes_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    whole = flushed_recording()
    cut, out = tmp_path / "killed.mcap", tmp_path / "fixed.mcap"
    cut.write_bytes(whole[: len(whole) // 2])
    held, _ = ticks_in(cut)
    assert held, "half the file holds some ticks"

    assert motocell("record", str(out), "--repair", str(cut)) == 0
    said = capsys.readouterr()
    copied = len(messages_before_the_cut(cut))
    assert said.out == (
        f"wrote {out}: {copied} messages from {cut} (all it held before its cut), with its "
        "summary\n"
    )
    assert messages_of_a_whole_file(out) == messages_before_the_cut(cut)
    with out.open("rb") as file:
        metadata = [(m.name, m.metadata) for m in make_reader(file).iter_metadata()]
    assert metadata == [("motocell.recording", {"key_exprs": "motocell/c/**"})]
    assert cut.read_bytes() == whole[: len(whole) // 2], "the cut file is left as it was"

    not_mcap = tmp_path / "notes.txt"
    not_mcap.write_text("notes\n")
    for argv, error in (
        ([str(tmp_path / "new.mcap"), "--repair", str(tmp_path / "absent.mcap")], "cannot read"),
        ([str(tmp_path / "new.mcap"), "--repair", str(not_mcap)], "not an MCAP file"),
        ([str(cut), "--repair", str(cut)], "would write over"),
    ):
        assert motocell("record", *argv) == 2, argv
        said = capsys.readouterr()
        assert error in said.err and said.err.count("\n") == 1, said.err
        assert not (tmp_path / "new.mcap").exists()
    assert cut.read_bytes() == whole[: len(whole) // 2]
