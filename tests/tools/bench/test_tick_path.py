"""Figure 3's tick-path measurement: the executor's real tick, four groups moving, in-process."""

from __future__ import annotations

from pathlib import Path

from motocell.services.executor.core.start import core_for_cell
from motocell.shared.bus.schemas import Decoder, IncrementBatch
from motocell.shared.motion.kinematics import AxisMap
from motocell.tools.bench.tick_path import BATCH, Feed, four_groups, tick_path_us


def test_every_tick_is_timed_and_the_groups_move_without_a_refusal() -> None:
    taken = tick_path_us(30)  # raises if the motion system refused a tick
    assert len(taken) == 30
    assert (taken > 0).all()


def test_the_feed_numbers_batches_as_an_interpolator_anew_after_a_cleared_ring(
    tmp_path: Path,
) -> None:
    cell = four_groups(tmp_path)
    core = core_for_cell(cell, None, first_epoch=1)
    feed = Feed(core, cell)
    decoder = Decoder(IncrementBatch)
    first = decoder.decode(feed.batch(0, 3))
    second = decoder.decode(feed.batch(0, 3))
    assert (first.first_seq, second.first_seq, second.count) == (0, BATCH, BATCH)
    used = AxisMap(cell.groups[0]).axes
    assert first.increments[: 4 * (used + 1)] == b"\x03\x00\x00\x00" * used + b"\0" * 4
    core.clear_all()
    assert decoder.decode(feed.batch(0, 3)).first_seq == 0
