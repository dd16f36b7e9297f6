"""``GoalRunner`` on a clock of the test's own, against a scripted motion API and scripted state:
points streamed in order with BUSY sent again, a cancel or an alarm stops the motion, a refused
first point is the goal's refusal, and a run ends only once the robot rests after its time."""

from __future__ import annotations

from collections import deque

import msgspec

from motocell.services.ros2.core.goal import Goal, GoalPoint, Plan, plan
from motocell.services.ros2.goal_runner import CANCELLED, GoalRunner
from motocell.shared.bus.schemas import RobotStatusFields, State
from motocell.shared.protocol.constants import Command, InvalidSubcode, MsgType, Result
from motocell.shared.protocol.messages import (
    JointTrajPtFull,
    Message,
    MotoMotionCtrl,
    MotoMotionReply,
)
from tests.services.ros2.scripted import MS, STATUS, face_cell, sample

CELL = face_cell()
NAMES = [[f"group_1/joint_{axis}" for axis in range(1, 7)]]
S = 1_000_000_000
T0 = 100 * S


def two_points() -> Plan:
    rest = (0.0,) * 6
    points = (GoalPoint(0, (0.25,) * 6, rest), GoalPoint(S // 10, (0.25,) * 6, rest))
    planned = plan(Goal(tuple(NAMES[0]), points, {}, 0), NAMES)
    assert isinstance(planned, Plan)
    return planned


class Cell:
    """The motion API's answers in turn (SUCCESS when none is left) and the state as it goes."""

    def __init__(self, results: list[tuple[Result, int]]) -> None:
        self.results = deque(results)
        self.asked: list[Message] = []
        self.now_ns = T0
        self.state: State | None = sample(CELL, T0 - MS)

    def request(self, message: Message) -> Message | None:
        self.asked.append(message)
        result, subcode = self.results.popleft() if self.results else (Result.SUCCESS, 0)
        reply = MotoMotionReply(0, 0, 0, int(result), subcode)
        return Message(int(MsgType.MOTO_MOTION_REPLY), 3, 1, reply)

    def sleep(self, seconds: float) -> None:
        self.now_ns += round(seconds * 1e9)
        # The robot comes to rest on the goal once the trajectory's time has passed.
        self.state = sample(CELL, self.now_ns - MS)

    def commands(self) -> list[int]:
        return [m.body.command for m in self.asked if isinstance(m.body, MotoMotionCtrl)]


def runner(cell: Cell) -> GoalRunner:
    return GoalRunner(
        cell,
        lambda: cell.state,
        CELL.groups,
        20 * MS,
        monotonic_ns=lambda: cell.now_ns,
        sleep=cell.sleep,
    )


def test_the_points_go_in_order_busy_again_and_the_run_ends_at_rest_on_its_goal() -> None:
    cell = Cell([(Result.SUCCESS, 0), (Result.BUSY, 0), (Result.BUSY, 0)])
    feedback: list[State] = []
    ending = runner(cell).run(two_points(), lambda: False, feedback.append)
    assert ending.error_code == 0
    sequences = [m.body.sequence for m in cell.asked if isinstance(m.body, JointTrajPtFull)]
    assert sequences == [0, 1, 1, 1], "the BUSY point sent again"
    assert ending.elapsed_ns >= S // 10
    assert feedback, "feedback while it ran"


def test_a_cancel_stops_the_motion() -> None:
    cell = Cell([])
    ending = runner(cell).run(two_points(), lambda: True, lambda state: None)
    assert ending.error_code == CANCELLED
    assert cell.commands() == [Command.STOP_MOTION]


def test_a_refused_first_point_is_the_goals_refusal_and_stops_nothing_moving() -> None:
    cell = Cell([(Result.INVALID, int(InvalidSubcode.DATA_START_POS))])
    ending = runner(cell).run(two_points(), lambda: False, lambda state: None)
    assert ending.error_code == -100204
    assert cell.commands() == [Command.STOP_MOTION]


def test_an_e_stop_while_it_runs_aborts_it_as_an_alarm() -> None:
    cell = Cell([(Result.BUSY, 0)] * 5)
    stopped = msgspec.structs.replace(STATUS, e_stopped=1)
    cell.state = msgspec.structs.replace(sample(CELL, T0), status=stopped)
    ending = runner(cell).run(two_points(), lambda: False, lambda state: None)
    assert ending.error_code == -100303
    assert cell.commands() == [Command.STOP_MOTION]


def test_the_run_waits_while_the_robot_still_moves() -> None:
    cell = Cell([])
    moving = RobotStatusFields(1, 0, 0, 0, 1, 2, 1)
    states = deque(
        [msgspec.structs.replace(sample(CELL, T0 + i * MS), status=moving) for i in range(50)]
    )

    def newest() -> State | None:
        return states.popleft() if states else sample(CELL, cell.now_ns)

    planned = two_points()
    runner_ = GoalRunner(
        cell, newest, CELL.groups, 20 * MS, monotonic_ns=lambda: cell.now_ns, sleep=cell.sleep
    )
    ending = runner_.run(planned, lambda: False, lambda state: None)
    assert ending.error_code == 0
    assert ending.elapsed_ns >= 50 * 5 * MS, "it waited out every state still in motion"
