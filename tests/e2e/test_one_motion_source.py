"""One controller, one motion source, from outside: the motion port's client and the ROS 2 face's
identity asking the gateway's motion API on ``gateway/cmd/motion`` (the face's own process is
skipped: this test speaks for it, over real Zenoh with its credentials). Whichever starts
trajectory mode holds it alone, each refusal in its own protocol's code; nobody else may ask."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator

import pytest
import zenoh

from motocell.shared.bus.catalog import Role
from motocell.shared.bus.schemas import Decoder, MotionRequest, MotionResponse, encode
from motocell.shared.protocol.codec import ByteOrder, decode_frames
from motocell.shared.protocol.codec import Role as Side
from motocell.shared.protocol.codec import encode as encode_frame
from motocell.shared.protocol.constants import Command, NotReadySubcode, Result
from motocell.shared.protocol.messages import MotoMotionReply
from motocell.shared.protocol.replies import motion_ctrl
from motocell.testing.processes import wait_until
from motocell.testing.running_cell import RunningCell, running_cell

pytestmark = pytest.mark.cell

ASK_TIMEOUT_S = 10.0
"""START_TRAJ_MODE waits up to 6 s for the controller; a bound for a hang, not a speed."""
DEADLINE_S = 30.0
"""For what takes well under a second: a bound for a hang, not a speed."""
OTHER_TRAJ_MODE_ACTIVE = 5014
"""MotoROS2's NOT_READY_OTHER_TRAJ_MODE_ACTIVE (114), as the gateway tells the face."""


@pytest.fixture(scope="module")
def cell(tmp_path_factory: pytest.TempPathFactory) -> Iterator[RunningCell]:
    cell_file = tmp_path_factory.mktemp("sources") / "cell.toml"
    cell_file.write_text('name = "sources"\n[ros2]\n')
    with running_cell(cell_file, skip=["ros2"], attempts=2) as running:
        yield running


def ask(session: zenoh.Session, cell: RunningCell, command: Command) -> tuple[int, int] | None:
    """The face's request; its reply's (result, subcode), None when nobody answered."""
    frame = encode_frame(motion_ctrl(command), ByteOrder.LITTLE, Side.CLIENT)
    key = cell.keys.gateway_cmd("motion")
    payload = encode(MotionRequest(frame))
    for reply in session.get(key, payload=payload, timeout=ASK_TIMEOUT_S):
        if reply.ok is not None:
            answer = Decoder(MotionResponse).decode(reply.ok.payload.to_bytes())
            (message,) = decode_frames(answer.frame, Side.CLIENT, ByteOrder.LITTLE)
            body = message.body
            assert isinstance(body, MotoMotionReply)
            return body.result, body.subcode
    return None


@pytest.fixture
def face(cell: RunningCell) -> Iterator[zenoh.Session]:
    session = cell.session(Role.ROS2)
    yield session
    ask(session, cell, Command.STOP_TRAJ_MODE)
    session.close()


def watch_shows(cell: RunningCell, words: str) -> None:
    """``motocell watch --count 1`` of the cell says ``words`` (the gateway tells who holds
    trajectory mode at least once a second): asked again until it does, or the deadline."""
    assert cell.credentials is not None
    command = [sys.executable, "-m", "motocell.tools.cli", "watch", "--count", "1"]
    command += ["--zenoh-connect", cell.zenoh_endpoint, "--credentials", str(cell.credentials)]
    command += ["--cell", cell.cell.name]

    def shown() -> bool:
        watched = subprocess.run(
            command, capture_output=True, text=True, timeout=DEADLINE_S, check=True
        )
        return f"trajectory mode: {words}" in watched.stdout

    wait_until(shown, DEADLINE_S, f"motocell watch to say: trajectory mode {words}")


def test_the_face_holds_trajectory_mode_and_the_motion_port_is_refused(
    cell: RunningCell, face: zenoh.Session
) -> None:
    assert ask(face, cell, Command.START_TRAJ_MODE) == (Result.SUCCESS, 0)
    watch_shows(cell, "held by the ROS 2 face")
    with cell.motion() as motion:
        refused = motion.command(Command.START_TRAJ_MODE)
        assert (refused.result, refused.subcode) == (Result.NOT_READY, NotReadySubcode.UNSPECIFIED)
        ready = motion.command(Command.CHECK_MOTION_READY)
        assert (ready.result, ready.subcode) == (Result.FALSE, NotReadySubcode.UNSPECIFIED)
        stop = motion.command(Command.STOP_TRAJ_MODE)
        assert stop.result == Result.FAILURE, "the motion port cannot end the face's mode"
    assert ask(face, cell, Command.CHECK_MOTION_READY) == (Result.TRUE, 0)
    assert ask(face, cell, Command.STOP_TRAJ_MODE) == (Result.SUCCESS, 0)
    with cell.motion() as motion:
        assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
        assert motion.command(Command.STOP_TRAJ_MODE).result == Result.SUCCESS


def test_the_motion_port_holds_trajectory_mode_and_the_face_is_refused(
    cell: RunningCell, face: zenoh.Session
) -> None:
    with cell.motion() as motion:
        assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
        watch_shows(cell, "held by the motion port's client")
        assert ask(face, cell, Command.START_TRAJ_MODE) == (
            Result.NOT_READY,
            OTHER_TRAJ_MODE_ACTIVE,
        )
        assert ask(face, cell, Command.STOP_MOTION) == (Result.FAILURE, 0)
    # The client gone (the gateway's clean-up runs after MotoROS's 50 ms pause), its mode is
    # given up: the face may start.
    wait_until(
        lambda: ask(face, cell, Command.START_TRAJ_MODE) == (Result.SUCCESS, 0),
        DEADLINE_S,
        "the face to start trajectory mode once the client has gone",
    )


def test_no_other_identity_may_use_the_faces_way_in(cell: RunningCell) -> None:
    for role in (Role.OBSERVER, Role.OPERATOR, Role.GATEWAY):
        session = cell.session(role)
        try:
            assert ask(session, cell, Command.START_TRAJ_MODE) is None, role
        finally:
            session.close()
