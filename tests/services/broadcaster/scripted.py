"""Scripted inputs for the broadcaster's tests: cells, ticks as the executor sends them, and a
controller whose status and token the test sets."""

from __future__ import annotations

from collections.abc import Sequence

import msgspec

from motocell.shared.bus.schemas import ControllerStatus, GroupTick, Tick
from motocell.shared.config import Cell, parse_cell
from motocell.testing.statuses import ready_status

MS = 1_000_000


def cell(*models: str, period_ms: float = 4.0, state_period_ms: float = 10.0) -> Cell:
    groups = [{"name": f"G{i}", "model": model} for i, model in enumerate(models or ("arm6",))]
    return parse_cell(
        {
            "interpolation_period_ms": period_ms,
            "state_period_ms": state_period_ms,
            "groups": groups,
        }
    )


def group_tick(
    command: Sequence[int] = (0,) * 8,
    feedback: Sequence[int] | None = None,
    increment: Sequence[int] = (0,) * 8,
    depth: int = 0,
    moved: Sequence[float] = (0.0,) * 8,
) -> GroupTick:
    """``moved``: what the feedback moved this period (the servo's), in pulses."""
    feedback = command if feedback is None else feedback
    return GroupTick(list(command), list(feedback), list(increment), depth, list(moved))


def tick(n: int = 1, deadline_ns: int = 0, *groups: GroupTick, lateness_ns: int = 0) -> Tick:
    return Tick(n, deadline_ns, lateness_ns, 0, True, list(groups or (group_tick(),)))


def resting_tick(n: int = 9) -> Tick:
    """The tick the executor's clock rests after (ticks every 4 ms)."""
    return msgspec.structs.replace(tick(n, n * 4 * MS), resting=True)


STATUS = ready_status(play=False)


def status(**changes: object) -> ControllerStatus:
    return msgspec.structs.replace(STATUS, **changes)


class FakeController:
    """A ``ControllerView`` that counts how often it is asked."""

    def __init__(self, status: ControllerStatus | None = STATUS, alive: bool = True) -> None:
        self.current = status
        self.present = alive
        self.asked = 0

    def status(self) -> ControllerStatus | None:
        self.asked += 1
        return self.current

    def alive(self) -> bool:
        return self.present
