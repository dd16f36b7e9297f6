"""The launcher's state table (``core/states.py``), row by row through ``RestartPolicy``: each
test brings a child's restart into the row's state, has the child found dead with the row's
exit, and checks what the policy says and when it means to restart it."""

from __future__ import annotations

from motocell.services.launcher.core.restarts import RestartPolicy
from motocell.services.launcher.core.states import RESTARTS, ChildState, Exit, Restart
from motocell.shared.config import EXIT_CONFIG

DELAY = 1.0
FOUND = 10.0
"""When the child is first found dead in the tests that schedule a restart."""
FAILED = 1


def in_state(state: ChildState) -> tuple[RestartPolicy, float]:
    """A policy whose child ``gateway/0`` is in ``state``, and the instant it is."""
    policy = RestartPolicy(delay_s=DELAY)
    if state is ChildState.RUNNING:
        return policy, FOUND
    assert policy.dead("gateway/0", FOUND, FAILED) is Restart.NOTICED
    now = FOUND + DELAY / 2 if state is ChildState.RESTART_PENDING else FOUND + DELAY
    assert policy.state("gateway/0", now) is state
    return policy, now


def test_running_failed_is_noticed_and_scheduled() -> None:
    policy, now = in_state(ChildState.RUNNING)
    assert policy.dead("gateway/0", now, FAILED) is Restart.NOTICED
    assert policy.next_restart() == now + DELAY
    assert policy.state("gateway/0", now) is ChildState.RESTART_PENDING


def test_restart_pending_failed_waits() -> None:
    policy, now = in_state(ChildState.RESTART_PENDING)
    assert policy.dead("gateway/0", now, FAILED) is Restart.WAIT
    assert policy.next_restart() == FOUND + DELAY


def test_restart_due_failed_restarts_now() -> None:
    policy, now = in_state(ChildState.RESTART_DUE)
    assert policy.dead("gateway/0", now, FAILED) is Restart.NOW
    assert policy.next_restart() is None
    assert policy.state("gateway/0", now) is ChildState.RUNNING


def test_running_cannot_start_gives_up() -> None:
    policy, now = in_state(ChildState.RUNNING)
    assert policy.dead("gateway/0", now, EXIT_CONFIG) is Restart.GIVE_UP
    assert policy.next_restart() is None


def test_restart_pending_cannot_start_gives_up() -> None:
    policy, now = in_state(ChildState.RESTART_PENDING)
    assert policy.dead("gateway/0", now, EXIT_CONFIG) is Restart.GIVE_UP
    assert policy.next_restart() == FOUND + DELAY


def test_restart_due_cannot_start_gives_up() -> None:
    policy, now = in_state(ChildState.RESTART_DUE)
    assert policy.dead("gateway/0", now, EXIT_CONFIG) is Restart.GIVE_UP
    assert policy.state("gateway/0", now) is ChildState.RESTART_DUE


def test_a_child_never_started_has_no_status_and_counts_as_failed() -> None:
    policy, now = in_state(ChildState.RUNNING)
    assert policy.dead("gateway/0", now, None) is Restart.NOTICED


def test_every_state_takes_every_exit() -> None:
    assert set(RESTARTS) == {(state, how) for state in ChildState for how in Exit}
