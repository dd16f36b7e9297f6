"""Which state client the port keeps (motoros1 §6)."""

from __future__ import annotations

import pytest

from motocell.services.broadcaster.core.admission import (
    MAX_STATE_CLIENTS,
    Admission,
    admission,
    queued,
)
from motocell.services.broadcaster.core.robot_status import IN_MOTION_PULSES, in_motion
from tests.services.broadcaster.scripted import group_tick, tick


@pytest.mark.parametrize("clients", range(MAX_STATE_CLIENTS))
@pytest.mark.parametrize("motion_queued", [False, True])
def test_up_to_four_state_clients_are_taken(clients: int, motion_queued: bool) -> None:
    assert admission(clients, motion_queued) is Admission.ACCEPT


def test_a_fifth_state_client_replaces_the_first_while_nothing_is_queued() -> None:
    assert admission(MAX_STATE_CLIENTS, motion_queued=False) is Admission.REPLACE_FIRST


def test_a_fifth_state_client_is_refused_while_motion_is_queued() -> None:
    assert admission(MAX_STATE_CLIENTS, motion_queued=True) is Admission.REFUSE


def test_motion_is_queued_while_any_ring_holds_entries() -> None:
    assert not queued(tick(1, 0, group_tick(), group_tick()))
    assert queued(tick(1, 0, group_tick(), group_tick(depth=1)))


def test_a_feedback_lag_alone_is_motion_but_queues_nothing() -> None:
    lagging = tick(1, 0, group_tick(command=[IN_MOTION_PULSES + 1] + [0] * 7, feedback=[0] * 8))
    assert in_motion(lagging) and not queued(lagging)
