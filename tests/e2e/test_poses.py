"""The arms' poses on ``state``, end to end: two arms and a positioner, the tool a client selects
with MOTO_SELECT_TOOL applied to the TCP (docs/poses.md)."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import zenoh

from motocell.shared.bus.schemas import Decoder, State
from motocell.shared.motion.forward_kinematics import Chain, pose, tool_transform
from motocell.shared.protocol.constants import Result
from motocell.shared.protocol.replies import select_tool
from motocell.testing.processes import wait_until
from motocell.testing.running_cell import RunningCell, running_cell

pytestmark = pytest.mark.cell

GRIPPER = (0.02, 0.0, 0.15, 0.0, 0.0, 1.0)
"""Tool 1: 0.150 m out of the flange face, 0.020 m to the side, turned 1 rad about its z."""
ARM7_START = (0.2, 0.3, -0.4, -0.5, 0.6, 0.4, -0.7)
CELL_FILE = f"""
name = "poses"
tools = [[0, 0, 0, 0, 0, 0], {list(GRIPPER)}]

[[groups]]
name = "R1"
model = "arm6"

[[groups]]
name = "R2"
model = "arm7"
initial_position = {list(ARM7_START)}

[[groups]]
name = "S1"
model = "positioner2"
"""
METRES = 1e-9


class NewestState:
    """The newest ``state`` sample an observer has received."""

    def __init__(self, session: zenoh.Session, key: str) -> None:
        self.state: State | None = None
        self._lock = threading.Lock()
        self._decoder = Decoder(State)
        self._subscriber = session.declare_subscriber(key, self._on_sample)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        state = self._decoder.decode(sample.payload.to_bytes())
        with self._lock:
            self.state = state

    def newest(self) -> State | None:
        with self._lock:
            return self.state

    def close(self) -> None:
        self._subscriber.undeclare()


@pytest.fixture(scope="module")
def cell(tmp_path_factory: pytest.TempPathFactory) -> Iterator[RunningCell]:
    path: Path = tmp_path_factory.mktemp("poses") / "poses.toml"
    path.write_text(CELL_FILE)
    with running_cell(path) as running:
        yield running


@pytest.fixture
def states(cell: RunningCell) -> Iterator[NewestState]:
    session = cell.session()
    newest = NewestState(session, cell.keys.state)
    try:
        wait_until(lambda: newest.newest() is not None, 10.0, "a state sample")
        yield newest
    finally:
        newest.close()
        session.close()


def test_every_arm_has_its_poses_and_the_positioner_none(
    cell: RunningCell, states: NewestState
) -> None:
    state = states.newest()
    assert state is not None
    arm6, arm7, positioner = state.groups
    assert positioner.flange is positioner.tcp is None
    np.testing.assert_allclose(arm7.positions, ARM7_START, atol=1e-4)
    for group in (arm6, arm7):
        chain = Chain(cell.cell.groups[group.group_no].model)
        # Each pose from its own joints: the feedback's and the command's differ while the
        # servo follows (docs/servo.md). Tool 0 is the flange.
        for joints, frames in (
            (group.positions, (group.flange, group.tcp)),
            (group.command_positions, (group.command_flange, group.command_tcp)),
        ):
            expected = pose(chain.flange(np.array(joints)))
            for frame in frames:
                assert frame is not None
                np.testing.assert_allclose(frame.position, expected.position, atol=METRES)
                np.testing.assert_allclose(frame.orientation, expected.orientation, atol=METRES)


def test_a_selected_tool_moves_the_tcp_and_not_the_flange(
    cell: RunningCell, states: NewestState
) -> None:
    with cell.motion() as motion:
        assert motion.motion(select_tool(1, 1)).result == Result.SUCCESS
    wait_until(
        lambda: (s := states.newest()) is not None and s.groups[1].tool == 1,
        5.0,
        "a state with tool 1 selected for R2",
    )
    state = states.newest()
    assert state is not None
    arm6, arm7, _ = state.groups
    assert arm6.tool == 0
    chain = Chain(cell.cell.groups[1].model)
    flange = chain.flange(np.array(arm7.positions))
    expected = pose(flange @ tool_transform(GRIPPER))
    commanded = pose(chain.flange(np.array(arm7.command_positions)) @ tool_transform(GRIPPER))
    assert arm7.flange is not None and arm7.tcp is not None and arm7.command_tcp is not None
    np.testing.assert_allclose(arm7.flange.position, pose(flange).position, atol=METRES)
    np.testing.assert_allclose(arm7.tcp.position, expected.position, atol=METRES)
    np.testing.assert_allclose(arm7.tcp.orientation, expected.orientation, atol=METRES)
    np.testing.assert_allclose(arm7.command_tcp.position, commanded.position, atol=METRES)
    np.testing.assert_allclose(arm7.command_tcp.orientation, commanded.orientation, atol=METRES)
    reach = np.linalg.norm(np.subtract(arm7.tcp.position, arm7.flange.position))
    assert reach == pytest.approx(np.hypot(0.02, 0.15), abs=METRES)
