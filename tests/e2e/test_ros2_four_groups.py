"""The ROS 2 face of a four-group cell (two arms, a track, a positioner), started through the
test plugin's API as a user starts one, driven by a real ROS 2 client: a goal and a point queue
over every group reach their ends, and a second cell with its face on the same machine and the
same ROS domain (another namespace) does not move or see the first one's traffic."""

from __future__ import annotations

import os
import random
from collections.abc import Iterator

import pytest

from motocell.testing import CellUnderTest, cell
from tests.e2e.ros2_caller import Caller

pytestmark = pytest.mark.cell

DOMAIN = random.randrange(1, 101)
FOUR = f"/f{os.getpid()}"
BESIDE = f"/b{os.getpid()}"
READY = [1, "Ready"]
FINAL_ERROR_RAD = 1e-4


@pytest.fixture(scope="module")
def beside() -> Iterator[CellUnderTest]:
    """A one-arm cell with its face on the same domain, in a namespace of its own."""
    with cell(ros2={"ros_domain_id": DOMAIN, "node_namespace": BESIDE}) as started:
        yield started


@pytest.fixture(scope="module")
def four(beside: CellUnderTest) -> Iterator[CellUnderTest]:
    with cell("four-group", ros2={"ros_domain_id": DOMAIN, "node_namespace": FOUR}) as started:
        yield started


@pytest.fixture(scope="module")
def caller(four: CellUnderTest) -> Iterator[Caller]:
    face = four.ros2
    assert face is not None
    started = Caller(face.ros_domain_id, face.node_namespace)
    yield started
    started.close()


def test_the_cell_object_says_where_its_face_is(four: CellUnderTest) -> None:
    assert four.ros2 is not None
    assert (four.ros2.ros_domain_id, four.ros2.node_namespace) == (DOMAIN, FOUR)
    assert four.ros2.node_name == f"motoman_{four.name}".replace("-", "_")


def test_a_goal_over_four_groups_reaches_its_end(
    four: CellUnderTest, beside: CellUnderTest, caller: Caller
) -> None:
    still = beside.positions()
    assert caller.ask("call", "start_traj_mode") == READY
    try:
        status, code, words, feedback, reached, goal = caller.ask("follow", "1.5", "0.1", "8")
        assert (status, code, words) == ("SUCCEEDED", 0, "Trajectory completed successfully!")
        assert len(goal) == sum(group.axes for group in four.config.groups) == 15
        assert max(abs(r - g) for r, g in zip(reached, goal, strict=True)) <= FINAL_ERROR_RAD
        assert feedback > 10
    finally:
        assert caller.ask("call", "stop_traj_mode")[0] is True
    assert beside.positions() == still, "the other cell on the machine did not move"


def test_points_queued_over_four_groups_reach_the_last(caller: Caller) -> None:
    assert caller.ask("call", "start_point_queue_mode") == READY
    try:
        codes, _, reached, last = caller.ask("queue", "1.5", "-0.1", "6")
        assert codes == [1] * 6
        assert max(abs(r - g) for r, g in zip(reached, last, strict=True)) <= FINAL_ERROR_RAD
    finally:
        assert caller.ask("call", "stop_traj_mode")[0] is True


def test_the_cell_beside_has_its_own_face(beside: CellUnderTest, caller: Caller) -> None:
    """Same domain, another namespace: its node is its own, with its own one group."""
    face = beside.ros2
    assert face is not None
    graph = caller.ask("graph", face.node_name, face.node_namespace)
    topics = dict((name, types) for name, types in graph["topics"])
    assert f"{BESIDE}/ctrl_groups/r1/joint_states" in topics
    assert f"{BESIDE}/ctrl_groups/r2/joint_states" not in topics
    assert not any(name.startswith(FOUR) for name in topics)
