"""Where the executor starts: its core built from the cell file, the robot's starting pulses
(the broadcaster's memory across a restart, else the cell file's), each group's range in
pulses."""

from __future__ import annotations

import pytest

from motocell.services.executor.core.rings import BatchOutcome
from motocell.services.executor.core.start import core_for_cell, pulse_ranges, starting_pulses
from motocell.shared.bus.schemas import CommandReply
from motocell.shared.config import parse_cell
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.protocol.constants import Result
from tests.services.executor.core.test_executor import START, batch, set_ready, unit


def test_pulse_ranges_follow_the_cell_in_motoman_order() -> None:
    cell = parse_cell(
        {
            "groups": [
                {"name": "R1", "model": "arm7", "joint_limits": [[-1.0, 1.0]] * 6 + [[-0.5, 0.25]]},
                {"name": "B1", "model": "track1"},
            ]
        }
    )
    (lower, upper), (track_lower, track_upper) = pulse_ranges(cell)
    # ROS T (the 7th) is Motoman T (the 6th); ROS E (the 3rd) is Motoman E (the 7th).
    assert upper[:7] == [65536, 65536, 65536, 36408, 36408, 6144, 65536]
    assert lower[5] == -12288
    assert lower[7] == upper[7] == 0
    assert (track_lower[0], track_upper[0]) == (-3_000_000, 3_000_000)
    assert track_lower[1:] == track_upper[1:] == [0] * 7


# -- where the robot starts ---------------------------------------------------------------

CELL = parse_cell(
    {
        "groups": [
            {"name": "R1", "model": "arm6", "initial_position": [1.0, 0, 0, 0, 0, -1.0]},
            {"name": "R2", "model": "positioner2", "initial_position": [0.5, 0]},
        ]
    }
)


def test_a_restarted_executor_resumes_where_the_controller_remembers() -> None:
    remembered = CommandReply(Result.SUCCESS, pulses=START)
    assert starting_pulses(CELL, remembered) == START


@pytest.mark.parametrize(
    "remembered",
    [
        None,
        CommandReply(Result.FAILURE, pulses=START),
        CommandReply(Result.SUCCESS, pulses=START[:1]),
        CommandReply(Result.SUCCESS),
    ],
)
def test_without_a_usable_memory_the_cell_files_initial_positions_are_used(
    remembered: CommandReply | None,
) -> None:
    # arm6: 58670 pulses/rad on S, 21990 on T; positioner2: 40000 pulses/rad.
    assert starting_pulses(CELL, remembered) == [
        [58670, 0, 0, 0, 0, -21990, 0, 0],
        [20000, 0, 0, 0, 0, 0, 0, 0],
    ]


def test_the_core_of_a_cell_starts_where_the_broadcaster_remembers() -> None:
    core = core_for_cell(CELL, CommandReply(Result.SUCCESS, pulses=START), first_epoch=7)
    assert core.command == START
    assert [ring.epoch for ring in core.rings] == [7, 8]
    assert core.period_ns == CELL.period_ns
    assert core.max_lateness_periods == CELL.max_lateness_periods


def test_the_core_of_a_cell_refuses_what_its_axes_cannot_do() -> None:
    """The speed limit of each axis comes from the cell's models: one pulse over it in one
    period is refused, and nothing moves."""
    core = core_for_cell(CELL, None, first_epoch=1)
    set_ready(core, True)
    fastest = AxisMap(CELL.groups[0]).max_increments(CELL.period_s)[0]
    assert core.accept(0, batch(1, 0, [unit(fastest), unit(fastest + 1)])) is (
        BatchOutcome.ACCEPTED
    )
    assert core.step() == []
    assert core.step() == [0]
    assert core.command[0][0] == starting_pulses(CELL, None)[0][0] + fastest
