"""A started cell's state at one moment, as a test reads it (``CellUnderTest.status()``) and a
failed test's report shows it: the controller's newest status, which face holds trajectory
mode, and every group's positions in the newest state snapshot."""

from __future__ import annotations

from dataclasses import dataclass

from motocell.shared.bus.schemas import Alarm, ControllerStatus, MotionHolder, State
from motocell.shared.config import Cell
from motocell.shared.protocol.constants import Result, describe_reply


@dataclass(frozen=True)
class CellStatus:
    servo_on: bool
    play: bool
    """PLAY mode (False: TEACH)."""
    remote: bool
    estop: bool
    hold: bool
    alarms: tuple[Alarm, ...]
    """Each with its ``code`` and ``subcode``, oldest first."""
    error: int
    """The active error's number (0: none); an error blocks motion but is not an alarm."""
    motion_ready: bool
    not_ready: int
    """Why motion is not ready: the NOT_READY subcode (motoros1 §7.2), 0 when it is."""
    trajectory_mode: MotionHolder
    """Which face holds trajectory mode (``NOBODY``: none does), as the gateway last said: on
    a client's connecting or leaving, and once a second, so up to a second old."""
    positions: tuple[tuple[float, ...], ...]
    """Each group's joint positions (radians, metres for a linear axis; ROS order)."""

    def lines(self) -> list[str]:
        """For a person: one line per fact, the positions one line per group."""
        ready = "yes" if self.motion_ready else describe_reply(Result.NOT_READY, self.not_ready)
        alarms = ", ".join(f"{alarm.code}.{alarm.subcode}" for alarm in self.alarms) or "none"
        return [
            f"servo {_on(self.servo_on)}, {'PLAY' if self.play else 'TEACH'}"
            f"{', REMOTE' if self.remote else ', not REMOTE'}",
            f"E-stop {_on(self.estop)}, HOLD {_on(self.hold)}",
            f"alarms (code.subcode): {alarms}; error: {self.error or 'none'}",
            f"motion ready: {ready}; trajectory mode: {self.trajectory_mode.name.lower()}",
            *(
                f"group {group} positions: {', '.join(f'{p:.6f}' for p in positions)}"
                for group, positions in enumerate(self.positions)
            ),
        ]


def _on(switch: bool) -> str:
    return "on" if switch else "off"


def cell_status(
    controller: ControllerStatus, holder: MotionHolder, state: State, cell: Cell
) -> CellStatus:
    """The snapshot of ``cell`` these three samples of its bus make."""
    return CellStatus(
        servo_on=controller.servo_on,
        play=controller.play,
        remote=controller.remote,
        estop=controller.estop,
        hold=controller.hold,
        alarms=tuple(controller.alarms),
        error=controller.error,
        motion_ready=controller.motion_ready,
        not_ready=controller.not_ready_subcode,
        trajectory_mode=holder,
        positions=tuple(
            tuple(group.positions[: cell.groups[index].axes])
            for index, group in enumerate(state.groups)
        ),
    )
