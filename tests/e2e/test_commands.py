"""Every MOTO_MOTION_CTRL command's reply (result, subcode) in the states that
matter (motoros1 §2.3)."""

from __future__ import annotations

import subprocess
from collections.abc import Callable

import pytest
import zenoh

from motocell.shared.bus.schemas import CommandRequest
from motocell.shared.bus.session import call
from motocell.shared.protocol.constants import Command, NotReadySubcode, Result
from motocell.shared.protocol.replies import motion_ctrl
from motocell.shared.registry import ENV as RUNTIME_DIR_ENV
from motocell.testing.client import MotionClient, StateListener, smooth_move, stream
from motocell.testing.running_cell import RunningCell

pytestmark = pytest.mark.cell


def fault(bus: zenoh.Session, cell: RunningCell, kind: str, value: int, *args: int) -> None:
    key = cell.keys.controller_fault(kind)
    reply = call(bus, key, CommandRequest(value=value, args=list(args)))
    assert reply is not None and reply.result == Result.SUCCESS


def answer(motion: MotionClient, command: Command) -> tuple[int, int]:
    reply = motion.command(command)
    assert reply.command == command
    return reply.result, reply.subcode


def start_moving(motion: MotionClient, state: StateListener) -> None:
    assert answer(motion, Command.START_TRAJ_MODE) == (Result.SUCCESS, 0)
    start = state.wait_still().groups[0].positions[:6]
    result = stream(motion, smooth_move(start, tuple(p + 0.3 for p in start), 1.5, 8))
    assert result.points == 8


@pytest.mark.parametrize(
    ("kind", "on", "off", "subcode"),
    [
        ("estop", 1, 0, NotReadySubcode.ESTOP),
        ("hold", 1, 0, NotReadySubcode.HOLD),
        ("remote", 0, 1, NotReadySubcode.NOT_REMOTE),
    ],
)
def test_start_traj_mode_refuses_what_needs_an_operator(
    cell: RunningCell,
    bus: zenoh.Session,
    motion: MotionClient,
    kind: str,
    on: int,
    off: int,
    subcode: NotReadySubcode,
) -> None:
    fault(bus, cell, kind, on)
    try:
        assert answer(motion, Command.START_TRAJ_MODE) == (Result.NOT_READY, subcode)
    finally:
        fault(bus, cell, kind, off)
    assert answer(motion, Command.START_TRAJ_MODE) == (Result.SUCCESS, 0)


def test_start_traj_mode_resets_alarms_and_errors(
    cell: RunningCell, bus: zenoh.Session, motion: MotionClient
) -> None:
    fault(bus, cell, "alarm", 1, 4100, 3)
    fault(bus, cell, "error", 1, 2010)
    assert answer(motion, Command.CHECK_MOTION_READY) == (Result.FALSE, NotReadySubcode.ALARM)
    assert answer(motion, Command.START_TRAJ_MODE) == (Result.SUCCESS, 0)
    assert answer(motion, Command.CHECK_MOTION_READY) == (Result.TRUE, 0)


def test_servo_commands(cell: RunningCell, bus: zenoh.Session, motion: MotionClient) -> None:
    assert answer(motion, Command.STOP_SERVOS) == (Result.SUCCESS, 0)
    assert answer(motion, Command.CHECK_MOTION_READY) == (Result.FALSE, NotReadySubcode.SERVO_OFF)
    fault(bus, cell, "estop", 1)
    assert answer(motion, Command.START_SERVOS) == (Result.FAILURE, 0)
    fault(bus, cell, "estop", 0)
    assert answer(motion, Command.START_SERVOS) == (Result.SUCCESS, 0)
    # Servo on again, but the job stopped with the servo: trajectory mode must be restarted.
    assert answer(motion, Command.CHECK_MOTION_READY) == (
        Result.FALSE,
        NotReadySubcode.NOT_STARTED,
    )
    assert answer(motion, Command.START_TRAJ_MODE) == (Result.SUCCESS, 0)


def test_reset_alarm(cell: RunningCell, bus: zenoh.Session, motion: MotionClient) -> None:
    fault(bus, cell, "alarm", 1, 4100, 1)
    fault(bus, cell, "alarm", 1, 4200, 2)
    assert answer(motion, Command.RESET_ALARM) == (Result.SUCCESS, 0)
    assert answer(motion, Command.CHECK_MOTION_READY) == (
        Result.FALSE,
        NotReadySubcode.SERVO_OFF,
    )
    assert answer(motion, Command.START_TRAJ_MODE) == (Result.SUCCESS, 0)


def test_stop_traj_mode_refuses_while_queued_then_ends_the_job(
    motion: MotionClient, state: StateListener
) -> None:
    start_moving(motion, state)
    assert answer(motion, Command.STOP_TRAJ_MODE) == (Result.FAILURE, 0)
    assert answer(motion, Command.STOP_MOTION) == (Result.SUCCESS, 0)
    assert answer(motion, Command.CHECK_QUEUE_CNT) == (Result.SUCCESS, 0)
    assert answer(motion, Command.CHECK_MOTION_READY) == (Result.TRUE, 0)
    assert answer(motion, Command.STOP_TRAJ_MODE) == (Result.SUCCESS, 0)
    assert answer(motion, Command.CHECK_MOTION_READY) == (
        Result.FALSE,
        NotReadySubcode.NOT_STARTED,
    )


def test_disconnect_fails_while_moving_and_closes_silently_when_idle(
    motion: MotionClient, state: StateListener
) -> None:
    start_moving(motion, state)
    assert answer(motion, Command.DISCONNECT) == (Result.FAILURE, 0)
    assert answer(motion, Command.STOP_MOTION) == (Result.SUCCESS, 0)
    motion.send(motion_ctrl(Command.DISCONNECT))
    motion.sock.settimeout(5.0)
    assert motion.sock.recv(1) == b"", "closed without a reply (MotoROS 1.9.4+)"


def test_the_fault_command_injects_and_clears(
    cell: RunningCell,
    motion: MotionClient,
    motocell: Callable[..., subprocess.CompletedProcess[str]],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # No endpoint, no credentials: the cell is found by name in the registry its launcher
    # wrote, as a cell started on this machine is, and joined as its operator.
    monkeypatch.setenv(RUNTIME_DIR_ENV, str(cell.runtime_dir))

    def fault_cli(*words: str) -> subprocess.CompletedProcess[str]:
        return motocell("fault", *words, "--cell", cell.cell.name)

    assert answer(motion, Command.START_TRAJ_MODE) == (Result.SUCCESS, 0)
    injected = fault_cli("estop", "on")
    assert injected.returncode == 0, injected.stderr
    assert "estop on: SUCCESS" in injected.stdout
    assert answer(motion, Command.CHECK_MOTION_READY) == (Result.FALSE, NotReadySubcode.ESTOP)
    assert fault_cli("estop", "off").returncode == 0
    assert answer(motion, Command.START_TRAJ_MODE) == (Result.SUCCESS, 0)
    refused = fault_cli("hold", "maybe")
    assert refused.returncode == 2 and "expected on or off" in refused.stderr
