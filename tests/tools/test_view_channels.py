"""What the view and the recording publish for Foxglove, read back from an MCAP file written by
``McapSink`` (``motocell record``'s writer, which carries the view's channels): each cell under
its own prefix, joints as the state has them, frames and geometry where the cell file puts
them, and a write that fails stopping the recording."""

from __future__ import annotations

import io
import json
from typing import Any

import msgspec
import pytest
from mcap.reader import make_reader

from motocell.shared.bus.schemas import (
    ControllerStatus,
    GroupState,
    GroupTick,
    RobotStatusFields,
    State,
    Tick,
)
from motocell.shared.config import Cell, load_cell
from motocell.tools.recording import McapSink, Recording
from motocell.tools.view_channels import SCENE_EVERY_NS
from tests.foxglove_ws import protobuf_class

START_NS = 1_800_000_000_000_000_000
PERIOD_NS = 10_000_000


def state(cell: Cell, seq: int) -> State:
    groups = [
        GroupState(g.index, [0.01 * seq] * g.axes, [0.1] * g.axes, [0.02 * seq] * g.axes)
        for g in cell.groups
    ]
    return State(seq, seq, 0, groups, RobotStatusFields(1, 0, 0, 0, 1, 2, 1))


def recorded(cells: list[Cell], known: list[Cell], states: int) -> dict[str, list[Any]]:
    """Record ``states`` states of each cell (``known``: the cell files the writer has), and
    return every message by topic, decoded."""
    stream = io.BytesIO()
    sink = McapSink(stream, cells={cell.name: cell for cell in known})
    for seq in range(states):
        for cell in cells:
            data = msgspec.msgpack.encode(state(cell, seq))
            sink.write(START_NS + seq * PERIOD_NS, f"motocell/{cell.name}/state", data)
    sink.finish()
    found: dict[str, list[Any]] = {}
    for schema, channel, message in make_reader(io.BytesIO(stream.getvalue())).iter_messages():
        assert schema is not None
        if channel.message_encoding == "protobuf":
            decoded: Any = protobuf_class(schema.name, schema.data).FromString(message.data)
        else:
            decoded = json.loads(message.data)
        found.setdefault(channel.topic, []).append(decoded)
    return found


def test_each_cell_under_its_own_prefix_each_group_by_its_name() -> None:
    default, dual = load_cell(), load_cell("dual-arm-positioner")
    topics = recorded([default, dual], [default, dual], 3)
    for cell in (default, dual):
        for group in cell.groups:
            joints = topics[f"/{cell.name}/{group.name}/joints"]
            assert [j["positions"] for j in joints] == [
                state(cell, n).groups[group.index].positions for n in range(3)
            ]
            assert joints[0]["command_positions"] == [0.0] * group.axes
        assert len(topics[f"/{cell.name}/transforms"]) == 3
        assert [s["in_motion"] for s in topics[f"/{cell.name}/robot_status"]] == [1, 1, 1]


def test_a_cell_without_its_file_gets_joints_but_no_scene() -> None:
    dual = load_cell("dual-arm-positioner")
    topics = recorded([dual], [], 2)
    assert {"/dual/group0/joints", "/dual/group2/joints"} <= set(topics)
    assert "/dual/transforms" not in topics and "/dual/scene" not in topics


def test_the_scene_comes_with_the_first_state_and_again_every_second() -> None:
    cell = load_cell()
    seconds = 3
    topics = recorded([cell], [cell], seconds * (SCENE_EVERY_NS // PERIOD_NS) + 1)
    scenes = topics["/cell1/scene"]
    assert len(scenes) == seconds + 1
    frames = {entity.frame_id for entity in scenes[0].entities}
    assert "cell1/R1/base" in frames and "cell1/R1/flange" in frames
    assert all(entity.frame_locked for entity in scenes[0].entities)


def test_status_and_executor_topics() -> None:
    stream = io.BytesIO()
    sink = McapSink(stream)
    status = ControllerStatus(
        1, True, False, True, [], 0, True, True, True, True, False, False, False, [], False, 1, [0]
    )
    tick = Tick(5, 0, 1_500_000, 0, True, [GroupTick([0], [0], [0], 7)])
    sink.write(START_NS, "motocell/cell1/controller/status", msgspec.msgpack.encode(status))
    sink.write(START_NS + 1, "motocell/cell1/executor/tick", msgspec.msgpack.encode(tick))
    sink.finish()
    messages = {
        channel.topic: json.loads(message.data)
        for _, channel, message in make_reader(io.BytesIO(stream.getvalue())).iter_messages()
    }
    shown = messages["/cell1/status"]
    assert (
        shown["servo_on"],
        shown["hold"],
        shown["motion_ready"],
        shown["not_ready_subcode"],
    ) == (True, True, False, 1)
    assert messages["/cell1/executor"] == {
        "tick": 5,
        "lateness_us": 1500.0,
        "missed": 0,
        "depths": [7],
    }
    assert sink.view.topics() == ["/cell1/executor", "/cell1/status"]


def test_reading_a_recording_back_gives_the_keys_not_the_views_topics(tmp_path: Any) -> None:
    cell = load_cell()
    path = tmp_path / "r.mcap"
    with path.open("wb") as stream:
        sink = McapSink(stream, cells={cell.name: cell})
        sink.write(START_NS, "motocell/cell1/state", msgspec.msgpack.encode(state(cell, 1)))
        sink.finish()
    assert [key for key, _, _ in Recording(path).messages()] == ["motocell/cell1/state"]


class FullDisk(io.BytesIO):
    def write(self, data: Any) -> int:
        raise OSError(28, "No space left on device")


def test_a_write_that_fails_stops_the_recording_with_its_error() -> None:
    cell = load_cell()
    sink = McapSink(FullDisk(), cells={cell.name: cell})
    with pytest.raises(OSError, match="No space left"):
        for seq in range(10_000):  # the writer fills a chunk before it writes
            sink.write(
                START_NS + seq, "motocell/cell1/state", msgspec.msgpack.encode(state(cell, seq))
            )
    with pytest.raises(OSError, match="No space left"):
        sink.finish()
