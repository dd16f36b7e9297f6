"""The restart policy, with time passed in: a dead child is noticed once, waits the delay, and
is started again; one that cannot start as configured stops the cell."""

from __future__ import annotations

from motocell.services.launcher.core.restarts import RESTART_DELAY_S, RestartPolicy
from motocell.services.launcher.core.states import Restart
from motocell.shared.config import EXIT_CONFIG


def test_a_dead_child_is_noticed_once_then_waits_then_restarts() -> None:
    policy = RestartPolicy(delay_s=1.0)
    assert policy.dead("executor", 10.0) is Restart.NOTICED
    assert policy.dead("executor", 10.2) is Restart.WAIT
    assert policy.dead("executor", 10.999) is Restart.WAIT
    assert policy.dead("executor", 11.0) is Restart.NOW


def test_a_child_that_cannot_start_as_configured_stops_the_cell() -> None:
    assert RestartPolicy().dead("gateway", 0.0, EXIT_CONFIG) is Restart.GIVE_UP
    assert RestartPolicy().dead("gateway", 0.0, 1) is Restart.NOTICED


def test_a_child_that_dies_again_after_its_restart_is_noticed_again() -> None:
    policy = RestartPolicy(delay_s=1.0)
    policy.dead("gateway", 0.0)
    assert policy.dead("gateway", 1.0) is Restart.NOW
    assert policy.dead("gateway", 5.0) is Restart.NOTICED
    assert policy.dead("gateway", 5.5) is Restart.WAIT
    assert policy.dead("gateway", 6.0) is Restart.NOW


def test_children_have_their_own_delays() -> None:
    policy = RestartPolicy(delay_s=1.0)
    policy.dead("executor", 0.0)
    assert policy.dead("interpolator/0", 0.5) is Restart.NOTICED
    assert policy.dead("executor", 1.0) is Restart.NOW
    assert policy.dead("interpolator/0", 1.0) is Restart.WAIT
    assert policy.dead("interpolator/0", 1.5) is Restart.NOW


def test_a_late_look_restarts_at_once() -> None:
    policy = RestartPolicy(delay_s=1.0)
    policy.dead("controller", 0.0)
    assert policy.dead("controller", 60.0) is Restart.NOW


def test_the_default_delay_is_a_second() -> None:
    assert RestartPolicy().delay_s == RESTART_DELAY_S == 1.0
