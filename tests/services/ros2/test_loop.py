"""The face's loop on a clock of the test's own, with scripted samples and recorded topics around
the real core: a sample is published as it comes, a rest is held at the period, and the loop
tells the samples when it must wake."""

from __future__ import annotations

from collections import deque

from motocell.services.ros2.core.face import Face
from motocell.services.ros2.core.topics import TopicValues
from motocell.services.ros2.loop import FaceLoop
from motocell.shared.bus.schemas import ControllerStatus, State
from motocell.testing.statuses import ready_status
from tests.services.ros2.scripted import MS, PERIOD_NS, face_cell, sample

T0 = 50_000 * MS
CELL = face_cell()


class Script:
    """``loop.Samples``: each ``next`` returns the next scripted (time, sample or None) and
    moves the clock there; the deadlines it was given are kept. The stop comes when the script
    ends."""

    def __init__(self, steps: list[tuple[int, State | None]]) -> None:
        self.steps = deque(steps)
        self.now_ns = T0
        self.deadlines: list[int | None] = []
        self.expected: list[bool] = []
        self.statuses: list[ControllerStatus | None] = []
        """What the loop reads at each wake-up, in turn."""

    def next(self, deadline_ns: int | None, samples_expected: bool) -> State | None:
        self.deadlines.append(deadline_ns)
        self.expected.append(samples_expected)
        self.now_ns, state = self.steps.popleft()
        return state

    def controller_status(self) -> ControllerStatus | None:
        return self.statuses.pop(0) if self.statuses else None

    def is_set(self) -> bool:
        return not self.steps

    def fileno(self) -> int:
        raise AssertionError("the loop never waits on the stop flag itself")


class Published:
    def __init__(self, observed: bool = True) -> None:
        self.values: list[TopicValues] = []
        self.read = observed

    def publish(self, values: TopicValues) -> None:
        self.values.append(values)

    def observed(self) -> bool:
        return self.read


def run(
    steps: list[tuple[int, State | None]],
    statuses: list[ControllerStatus | None] | None = None,
    observed: bool = True,
) -> tuple[Script, Published]:
    assert CELL.ros2 is not None
    script, published = Script(steps), Published(observed)
    script.statuses = statuses or []
    FaceLoop(Face(CELL, CELL.ros2), script, published, lambda: script.now_ns).run(script)
    return script, published


def test_samples_go_out_as_they_come_and_a_rest_is_held_at_the_period() -> None:
    hold_at = T0 + PERIOD_NS * 3 // 2
    script, published = run(
        [
            (T0, sample(CELL, T0 - MS)),
            (hold_at, None),  # woken at the deadline it was given
            (hold_at + PERIOD_NS, None),
            (hold_at + PERIOD_NS + 2 * MS, sample(CELL, hold_at + PERIOD_NS + MS, 0.5)),
        ]
    )
    assert script.deadlines == [None, hold_at, hold_at + PERIOD_NS, hold_at + 2 * PERIOD_NS]
    # Holding, the loop wakes at its deadlines only; following, for every sample.
    assert script.expected == [True, True, False, False]
    # A held sample's joint values are those already published: the node sends them again.
    first, held, held_again, _ = published.values
    assert first.positions is held.positions is held_again.positions
    assert [values.sampled_ns for values in published.values] == [
        T0 - MS,
        hold_at,
        hold_at + PERIOD_NS,
        hold_at + PERIOD_NS + MS,
    ]
    assert published.values[-1].positions == (0.5,) * 6


def test_unread_the_loop_waits_for_a_sample_or_a_reader_not_for_the_period() -> None:
    """Nobody subscribes: no deadline, so no wake-up every period; what comes (a sample, the
    doorbell of a new reader) is handed on as ever."""
    script, _ = run([(T0, sample(CELL, T0 - MS)), (T0 + 700 * MS, None)], observed=False)
    assert script.deadlines == [None, None]


def test_a_wake_up_before_the_deadline_publishes_nothing() -> None:
    _, published = run([(T0, sample(CELL, T0)), (T0 + MS, None)])
    assert len(published.values) == 1


def test_a_resting_robots_status_follows_the_controller_within_a_period() -> None:
    """At rest the cell's state comes once a second; the controller's status, read at every
    wake-up, goes out with the next held publication."""
    hold_at = T0 + PERIOD_NS * 3 // 2
    estop = ready_status(estop=True, motion_ready=False)
    _, published = run([(T0, sample(CELL, T0 - MS)), (hold_at, None)], [None, estop])
    first, held = published.values
    assert (first.status.e_stopped, first.status.motion_possible) == (0, 1)
    assert (held.status.e_stopped, held.status.motion_possible) == (1, 0)
