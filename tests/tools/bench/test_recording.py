"""The measuring processes' records: bounded columns, and the state recorder's frames to pulses."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from motocell.shared.config import load_cell
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.protocol.codec import ByteOrder, Role, SimpleMessageCodec
from motocell.shared.protocol.constants import MsgType
from motocell.shared.protocol.messages import JointFeedback, RobotStatus
from motocell.shared.protocol.replies import state_message
from motocell.tools.bench.measuring import write_cell_file
from motocell.tools.bench.recording import Columns
from motocell.tools.bench.state_client import INCOMPLETE, StateRecorder, capacity

STATUS = RobotStatus(1, 0, 0, 0, 1, 1, 1)


def test_columns_keep_rows_up_to_their_capacity_and_count_the_rest() -> None:
    columns = Columns(2, ("a", "b"))
    for value in range(5):
        columns.add(value, -value)
    arrays = columns.arrays()
    assert arrays["a"].tolist() == [0, 1]
    assert arrays["b"].tolist() == [0, -1]
    assert columns.dropped == 3


def test_capacity_covers_the_run_at_the_state_rate_with_headroom() -> None:
    # 60 s at 250 Hz is 15 000 cycles; the record holds more.
    assert capacity(60.0, 4_000_000) >= 15_000 * 1.25


def feedback(group: int, positions: list[float]) -> JointFeedback:
    padded = tuple(positions + [0.0] * (10 - len(positions)))
    return JointFeedback(group, 2, 0.0, padded, (0.0,) * 10, (0.0,) * 10)


def frames(codec: SimpleMessageCodec, bodies: list[JointFeedback | RobotStatus]) -> bytes:
    data = b""
    for body in bodies:
        kind = MsgType.ROBOT_STATUS if isinstance(body, RobotStatus) else MsgType.JOINT_FEEDBACK
        data += codec.send(state_message(kind, body))
    return data


def test_the_recorder_turns_each_cycle_into_pulses_stamped_with_its_read(tmp_path: Path) -> None:
    cell = load_cell(write_cell_file(tmp_path, "rec", models=("arm6", "positioner2")))
    server = SimpleMessageCodec(Role.CONTROLLER, ByteOrder(cell.byte_order))
    recorder = StateRecorder(cell, rows=2)
    arm = [0.1, -0.2, 0.3, 0.0, 0.5, -0.6]
    station = [1.0, -1.5]
    cycle = frames(server, [feedback(0, arm), feedback(1, station), STATUS])
    # One read with a whole cycle and the start of the next; the rest in a second read.
    assert recorder.feed(cycle + cycle[:10], 111)
    assert recorder.feed(cycle[10:], 222)
    assert recorder.rows == 2
    assert recorder.received_ns.tolist() == [111, 222]
    expected = np.concatenate(
        [
            AxisMap(cell.groups[0]).ros_to_pulses(np.array(arm, dtype=np.float32)),
            AxisMap(cell.groups[1]).ros_to_pulses(np.array(station, dtype=np.float32)),
        ]
    )
    assert recorder.pulses().tolist() == [expected.tolist()] * 2


def test_a_cycle_missing_a_group_is_incomplete_and_cycles_past_the_bound_are_counted(
    tmp_path: Path,
) -> None:
    cell = load_cell(write_cell_file(tmp_path, "rec", models=("arm6", "positioner2")))
    server = SimpleMessageCodec(Role.CONTROLLER, ByteOrder(cell.byte_order))
    recorder = StateRecorder(cell, rows=1)
    recorder.feed(frames(server, [feedback(0, [0.1] * 6), STATUS, STATUS, STATUS]), 5)
    assert recorder.rows == 1
    assert recorder.dropped == 2
    assert (recorder.pulses() == INCOMPLETE).all()


def test_the_recorder_reports_a_closed_connection(tmp_path: Path) -> None:
    cell = load_cell(write_cell_file(tmp_path, "rec"))
    recorder = StateRecorder(cell, rows=1)
    assert not recorder.feed(b"", 0)
