"""Which state client the port keeps (motoros1 §6): up to four; a fifth is refused while motion
data is queued, else it takes the first one's place."""

from __future__ import annotations

from enum import Enum

from motocell.shared.bus.schemas import Tick

MAX_STATE_CLIENTS = 4
"""MotoROS 1.9.4+ serves up to 4 state clients, each with its own sender (motoros1 §6)."""


class Admission(Enum):
    ACCEPT = "accept"
    REFUSE = "refuse"
    REPLACE_FIRST = "replace the first"


def queued(tick: Tick) -> bool:
    """Motion data is queued for some group: MotoROS then refuses a 5th state client."""
    return any(group.depth > 0 for group in tick.groups)


def admission(clients: int, motion_queued: bool) -> Admission:
    """What the state port does with a newcomer when ``clients`` are connected (motoros1 §6):
    up to 4; a 5th is refused while motion data is queued, otherwise slot 0 is closed and
    reused."""
    if clients < MAX_STATE_CLIENTS:
        return Admission.ACCEPT
    return Admission.REFUSE if motion_queued else Admission.REPLACE_FIRST
