"""One controller, one motion source: the motion port's client and the ROS 2 face share the cell,
and whichever started trajectory mode holds it alone until it stops it, disconnects, or the
controller's job ends. Both handlers on one fake cell, as in the gateway."""

from __future__ import annotations

import itertools

import pytest

from motocell.services.gateway.core.motion import MotionHandler
from motocell.services.gateway.core.robot_io import RobotIoHandler
from motocell.services.gateway.core.sources import OTHER_HOLDS_SUBCODE, MotionSources, Source
from motocell.shared.bus.schemas import CommandReply
from motocell.shared.protocol.constants import Command, NotReadySubcode, Result
from motocell.shared.protocol.replies import motion_ctrl, traj_point
from tests.services.gateway.core.fake_cell import (
    NOW,
    SYNC_SEED,
    FakeCell,
    exchange,
    one_group,
    reply_of,
    status,
)

SM, ROS2 = Source.SIMPLE_MESSAGE, Source.ROS2


def two_faces() -> tuple[MotionHandler, MotionHandler, FakeCell]:
    cell = one_group()
    fake = FakeCell(1).ready()
    sync_ids = itertools.count(SYNC_SEED + 1)
    io = RobotIoHandler(fake)
    return (
        MotionHandler(cell, fake, io, sync_ids, SM),
        MotionHandler(cell, fake, io, sync_ids, ROS2),
        fake,
    )


def verdict(handler: MotionHandler, command: Command) -> tuple[int, int]:
    reply = reply_of(exchange(handler, motion_ctrl(command)).reply)
    return reply.result, reply.subcode


def test_the_face_that_started_trajectory_mode_holds_it_and_the_other_is_refused() -> None:
    simple_message, face, cell = two_faces()
    assert verdict(face, Command.START_TRAJ_MODE) == (Result.SUCCESS, 0)
    refused = (Result.NOT_READY, OTHER_HOLDS_SUBCODE[SM])
    assert verdict(simple_message, Command.START_TRAJ_MODE) == refused
    assert verdict(simple_message, Command.CHECK_MOTION_READY) == (Result.FALSE, refused[1])
    assert cell.verbs("controller") == ["start_traj_mode"], "the refusal asks nobody"
    point = traj_point(0, 0, 0.0, (0.0,) * 6, (0.0,) * 6)
    reply = reply_of(exchange(simple_message, point).reply)
    assert (reply.result, reply.subcode) == refused
    assert cell.sent == [], "nothing of the other face's reaches the robot"
    # The holder's readiness is untouched.
    assert verdict(face, Command.CHECK_MOTION_READY) == (Result.TRUE, 0)


def test_each_face_hears_the_refusal_in_its_own_protocols_words() -> None:
    simple_message, face, _ = two_faces()
    assert verdict(simple_message, Command.START_TRAJ_MODE) == (Result.SUCCESS, 0)
    # MotoROS2's NOT_READY_OTHER_TRAJ_MODE_ACTIVE, 114, in the face's 5000 + n numbering.
    assert verdict(face, Command.START_TRAJ_MODE) == (Result.NOT_READY, 5014)
    assert OTHER_HOLDS_SUBCODE[SM] == NotReadySubcode.UNSPECIFIED


@pytest.mark.parametrize("ends", [Command.STOP_MOTION, Command.STOP_TRAJ_MODE])
def test_the_other_face_cannot_stop_the_holders_motion(ends: Command) -> None:
    simple_message, face, cell = two_faces()
    verdict(face, Command.START_TRAJ_MODE)
    assert verdict(simple_message, ends) == (Result.FAILURE, 0)
    assert "stop" not in cell.verbs("executor") and "stop_traj_mode" not in cell.verbs("controller")


def test_a_client_gone_stops_its_own_motion_only() -> None:
    simple_message, face, cell = two_faces()
    verdict(face, Command.START_TRAJ_MODE)
    simple_message.disconnected()
    assert cell.verbs("executor") == [], "the face's motion goes on"
    face.disconnected()
    assert cell.verbs("executor") == ["stop"]
    assert verdict(simple_message, Command.START_TRAJ_MODE) == (Result.SUCCESS, 0)


def test_stop_traj_mode_gives_trajectory_mode_up() -> None:
    simple_message, face, _ = two_faces()
    verdict(face, Command.START_TRAJ_MODE)
    assert verdict(face, Command.STOP_TRAJ_MODE) == (Result.SUCCESS, 0)
    assert verdict(simple_message, Command.START_TRAJ_MODE) == (Result.SUCCESS, 0)


def test_when_the_controllers_job_ends_the_other_face_may_start() -> None:
    """An E-stop or a servo off ends the job, and with it the holder's trajectory mode."""
    simple_message, face, cell = two_faces()
    verdict(face, Command.START_TRAJ_MODE)
    cell.state.on_status(status(ready=False, subcode=int(NotReadySubcode.ESTOP)), NOW)
    cell.effects["controller/start_traj_mode"] = lambda: cell.state.on_status(status(), NOW)
    assert verdict(simple_message, Command.START_TRAJ_MODE) == (Result.SUCCESS, 0)
    assert verdict(face, Command.CHECK_MOTION_READY)[1] == OTHER_HOLDS_SUBCODE[ROS2]


def test_a_start_the_controller_refuses_holds_nothing() -> None:
    simple_message, face, cell = two_faces()
    hold = int(NotReadySubcode.HOLD)
    cell.replies["controller/start_traj_mode"] = CommandReply(int(Result.NOT_READY), hold)
    assert verdict(face, Command.START_TRAJ_MODE) == (Result.NOT_READY, hold)
    del cell.replies["controller/start_traj_mode"]
    assert verdict(simple_message, Command.START_TRAJ_MODE) == (Result.SUCCESS, 0)


def test_a_start_under_way_already_holds_trajectory_mode() -> None:
    """The holder is taken before the controller is asked: two faces starting at once
    cannot both win, though the job runs only once the controller answers."""
    sources = MotionSources()
    sources.begin_start(ROS2)
    assert sources.held_by_other(SM, operating=False)
    sources.end_start(ROS2, started=True)
    assert sources.held_by_other(SM, operating=True)
    assert not sources.held_by_other(SM, operating=False)
    assert not sources.held_by_other(ROS2, operating=True)


def test_the_holder_shown_is_the_one_whose_job_runs_or_is_starting() -> None:
    sources = MotionSources()
    assert sources.holding(operating=True) is None
    sources.begin_start(Source.ROS2)
    assert sources.holding(operating=False) is Source.ROS2, "starting"
    sources.end_start(Source.ROS2, started=True)
    assert sources.holding(operating=True) is Source.ROS2
    assert sources.holding(operating=False) is None, "its job ended (an E-stop)"
    sources.release(Source.ROS2)
    assert sources.holding(operating=True) is None
