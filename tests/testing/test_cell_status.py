"""A cell's status from its bus's samples, and as a failed test's report shows it."""

from __future__ import annotations

from motocell.shared.bus.schemas import Alarm, GroupState, MotionHolder, RobotStatusFields, State
from motocell.shared.config import load_cell
from motocell.shared.protocol.constants import NotReadySubcode
from motocell.testing.cell_status import cell_status
from motocell.testing.statuses import ready_status

FOUR_GROUPS = load_cell("four-group")


def state_of(positions: list[list[float]]) -> State:
    groups = [GroupState(g, [*p, 9.0], [0.0] * (len(p) + 1), p) for g, p in enumerate(positions)]
    return State(1, 2, 3, groups, RobotStatusFields(1, 0, 0, 0, 0, 2, 1))


def test_a_ready_cell_reads_as_ready_with_each_groups_positions_and_no_more_axes() -> None:
    positions = [[0.0] * group.axes for group in FOUR_GROUPS.groups]
    positions[3][-1] = 0.25
    status = cell_status(ready_status(), MotionHolder.MOTION_PORT, state_of(positions), FOUR_GROUPS)
    assert status.positions == tuple(tuple(p) for p in positions)
    assert status.lines()[:4] == [
        "servo on, PLAY, REMOTE",
        "E-stop off, HOLD off",
        "alarms (code.subcode): none; error: none",
        "motion ready: yes; trajectory mode: motion_port",
    ]
    assert status.lines()[4 + 3].endswith(", 0.250000")
    assert len(status.lines()) == 4 + len(FOUR_GROUPS.groups)


def test_an_estopped_cell_in_teach_names_its_alarms_error_and_why_it_is_not_ready() -> None:
    controller = ready_status(
        servo_on=False,
        estop=True,
        play=False,
        remote=False,
        alarms=[Alarm(4100, 2), Alarm(4321)],
        error=2010,
        motion_ready=False,
        not_ready_subcode=NotReadySubcode.ESTOP,
    )
    cell = load_cell(None)
    status = cell_status(controller, MotionHolder.NOBODY, state_of([[0.0] * 6]), cell)
    assert status.alarms == (Alarm(4100, 2), Alarm(4321, 0))
    assert status.lines()[:4] == [
        "servo off, TEACH, not REMOTE",
        "E-stop on, HOLD off",
        "alarms (code.subcode): 4100.2, 4321.0; error: 2010",
        "motion ready: NOT_READY 5003 (E-stop); trajectory mode: nobody",
    ]
