"""The arms' flange and TCP poses, for observers (docs/poses.md)."""

from __future__ import annotations

import math

import pytest

from motocell.services.broadcaster.core.broadcaster import Broadcaster
from motocell.shared.bus.schemas import GroupTick, State
from motocell.shared.config import parse_cell
from tests.services.broadcaster.core.test_joints import ARM6_PPU
from tests.services.broadcaster.scripted import FakeController, cell, group_tick, status, tick

ARM6_HOME_FLANGE = [0.560, 0.0, 0.815]
"""The GP7's flange at all-zero joints (tests/shared/motion/test_forward_kinematics.py)."""
ARM6_HOME_ORIENTATION = [math.sqrt(0.5), 0.0, math.sqrt(0.5), 0.0]
"""Flange z forward, x up: a half turn about (x + z) / sqrt(2)."""


def posed(broadcaster: Broadcaster, *groups: GroupTick) -> State:
    state = broadcaster.on_tick(tick(1, 0, *groups), 0.0)
    assert state is not None
    return broadcaster.for_observers(state)


def test_arms_get_flange_and_tcp_poses_and_positioners_none() -> None:
    dual = parse_cell({"groups": [{"model": "arm6"}, {"name": "R2", "model": "positioner2"}]})
    state = posed(Broadcaster(dual, FakeController()), group_tick(), group_tick())
    arm, positioner = state.groups
    for pose in (arm.flange, arm.tcp, arm.command_flange, arm.command_tcp):
        assert pose is not None
        assert pose.position == pytest.approx(ARM6_HOME_FLANGE, abs=2e-5)
        assert pose.orientation == pytest.approx(ARM6_HOME_ORIENTATION, abs=2e-5)
    assert positioner.flange is positioner.tcp is positioner.command_tcp is None


def test_feedback_and_commanded_poses_follow_their_own_joints() -> None:
    """S commanded a quarter turn, the feedback still at 0: the commanded flange faces +y."""
    quarter = round(math.pi / 2 * ARM6_PPU[0])
    state = posed(
        Broadcaster(cell(), FakeController()),
        group_tick(command=[quarter] + [0] * 7, feedback=[0] * 8),
    )
    (arm,) = state.groups
    assert arm.flange is not None and arm.command_flange is not None
    assert arm.flange.position == pytest.approx(ARM6_HOME_FLANGE, abs=2e-5)
    assert arm.command_flange.position == pytest.approx([0.0, 0.560, 0.815], abs=2e-5)


def test_the_tcp_uses_the_tool_the_controller_has_selected() -> None:
    """Tool 1 reaches 0.100 out of the flange face, which points forward at home."""
    tooled = parse_cell({"tools": [[0.0] * 6, [0, 0, 0.100, 0, 0, 0]]})
    state = posed(Broadcaster(tooled, FakeController(status(tools=[1]))), group_tick())
    (arm,) = state.groups
    assert arm.tool == 1
    assert arm.tcp is not None and arm.command_tcp is not None
    assert arm.tcp.position == pytest.approx([0.660, 0.0, 0.815], abs=2e-5)
    assert arm.command_tcp.position == arm.tcp.position


def test_without_a_controller_status_the_tcp_is_tool_0() -> None:
    tooled = parse_cell({"tools": [[0, 0, 0.100, 0, 0, 0]]})
    state = posed(Broadcaster(tooled, FakeController(status=None)), group_tick())
    (arm,) = state.groups
    assert arm.tool == 0
    assert arm.tcp is not None
    assert arm.tcp.position == pytest.approx([0.660, 0.0, 0.815], abs=2e-5)


def test_a_moment_without_a_status_keeps_the_selected_tool() -> None:
    """The TCP does not jump back to the flange for a snapshot the controller had no status
    for: the last tool it selected stays."""
    tooled = parse_cell({"tools": [[0.0] * 6, [0, 0, 0.100, 0, 0, 0]]})
    controller = FakeController(status(tools=[1]))
    broadcaster = Broadcaster(tooled, controller)
    posed(broadcaster, group_tick())
    controller.current = None
    state = broadcaster.on_wake(10.0, clients=True)  # ticks stopped: a silent beat
    assert state is not None
    (arm,) = broadcaster.for_observers(state).groups
    assert arm.tool == 1
    assert arm.tcp is not None
    assert arm.tcp.position == pytest.approx([0.660, 0.0, 0.815], abs=2e-5)
