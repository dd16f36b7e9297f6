"""The servo model: ideal is the identity, a position loop lags a ramp by its closed-form
following error, comes to rest exactly on the command, never leaves the range of the commands
it was given, and stops dead when braked."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from motocell.shared.config import IdealServo, PositionLoop
from motocell.shared.motion.servo import Servos, ramp_following_error

PERIOD_S = 0.004
LOOP = PositionLoop()
"""The catalogue's default: gain 40/s, feed-forward 0.5, filter 12 ms."""


def rows(*axes: int) -> list[list[int]]:
    return [[*axes, *([0] * (8 - len(axes)))]]


def ramp(servos: Servos, step: int, periods: int, start: int = 0) -> int:
    """Axis 0 of group 0 commanded ``step`` more pulses every period; returns the command."""
    command = start
    for _ in range(periods):
        command += step
        servos.step(rows(command))
    return command


def settle(servos: Servos, command: list[list[int]], limit: int = 1000) -> int:
    """Periods until every axis reads ``command`` exactly and stands still."""
    for period in range(1, limit + 1):
        servos.step(command)
        if servos.feedback_pulses() == command and not any(map(any, servos.moved)):
            return period
    raise AssertionError(f"not at rest on {command} after {limit} periods")


def test_ideal_is_the_identity() -> None:
    rng = np.random.default_rng(1)
    start = rng.integers(-1000, 1000, (2, 8))
    servos = Servos([IdealServo(), IdealServo()], PERIOD_S, start.tolist())
    command = start
    for _ in range(200):
        increment = rng.integers(-500, 500, (2, 8))
        command = command + increment
        servos.step(command.tolist())
        assert servos.feedback_pulses() == command.tolist()
        assert servos.position == command.tolist()
        assert servos.moved == increment.tolist()


def test_a_step_is_followed_from_behind_and_reached_exactly() -> None:
    servos = Servos([LOOP], PERIOD_S, rows(0))
    servos.step(rows(1000))
    assert 0 < servos.position[0][0] < 1000, "a servo takes more than one period to follow"
    # 25 ms per e-fold of the loop: 1000 pulses to half a pulse in 0.2-0.5 s.
    assert 50 <= settle(servos, rows(1000)) <= 125


def test_the_step_response_rises_monotonically() -> None:
    servos = Servos([LOOP], PERIOD_S, rows(0))
    previous = 0.0
    for _ in range(200):
        servos.step(rows(1000))
        assert servos.position[0][0] >= previous
        previous = float(servos.position[0][0])


@pytest.mark.parametrize(
    "settings_",
    [
        LOOP,
        PositionLoop(gain=20.0, feed_forward=0.0, filter_ms=0.0),
        PositionLoop(gain=100.0, feed_forward=0.9, filter_ms=4.0),
        PositionLoop(gain=40.0, feed_forward=1.0, filter_ms=20.0),
    ],
)
def test_a_ramp_is_followed_with_the_closed_form_error(settings_: PositionLoop) -> None:
    step = 1537
    servos = Servos([settings_], PERIOD_S, rows(0))
    command = ramp(servos, step, 500)  # 2 s: every transient has died out
    error = command - servos.position[0][0]
    assert error == pytest.approx(ramp_following_error(settings_, PERIOD_S, step), rel=1e-9)
    assert servos.moved[0][0] == pytest.approx(step, rel=1e-9)


def test_the_default_lags_a_steady_command_by_about_22_ms() -> None:
    """docs/servo.md: 10.1 ms of filter and half of 23.0 ms of loop at 4 ms periods, near the
    continuous 12 ms + 0.5 / 40 s."""
    lag_s = ramp_following_error(LOOP, PERIOD_S, 1.0) * PERIOD_S
    assert lag_s == pytest.approx(0.0216, abs=0.0001)
    assert lag_s == pytest.approx(0.012 + 0.5 / 40, rel=0.15)


def test_after_a_ramp_the_feedback_comes_to_rest_exactly_on_the_command() -> None:
    servos = Servos([LOOP], PERIOD_S, rows(0, 5))
    command = ramp(servos, 2000, 100)
    assert servos.feedback_pulses()[0][0] < command - 1000, "it lags while moving"
    settle(servos, rows(command, 5))
    assert servos.position == [[command, 5, 0, 0, 0, 0, 0, 0]]
    assert servos.filtered == servos.lagged == servos.position


def test_a_stop_comes_to_rest_from_behind_with_continuous_velocity() -> None:
    """STOP_MOTION, HOLD, a cancelled trajectory: the command freezes mid-motion and the
    feedback decelerates through the servo's response onto it, never past it."""
    servos = Servos([LOOP], PERIOD_S, rows(0))
    command = ramp(servos, 2000, 100)
    before = float(servos.moved[0][0])
    servos.step(rows(command))
    after = float(servos.moved[0][0])
    assert 0.5 * before < after < before, "the filter keeps the velocity continuous"
    velocities = [after]
    while servos.moved[0][0] != 0:
        servos.step(rows(command))
        assert servos.position[0][0] <= command
        velocities.append(float(servos.moved[0][0]))
    assert all(v >= 0 for v in velocities), "it never moves back"
    assert servos.feedback_pulses()[0][0] == command


@given(
    seed=st.integers(0, 2**32 - 1),
    gain=st.floats(1.0, 500.0),
    feed_forward=st.floats(0.0, 1.0),
    filter_ms=st.floats(0.0, 50.0),
)
def test_the_feedback_never_leaves_the_range_of_the_commands(
    seed: int, gain: float, feed_forward: float, filter_ms: float
) -> None:
    """Commands that reverse and stop at the limits: the feedback stays within [lower, upper]
    (a convex combination of the commands so far, computed in doubles: within their rounding,
    a few 1e-12 pulses), so the encoder never reads past a joint limit the command respects."""
    lower, upper = -5000, 5000
    rounding = 1e-9  # pulses; found: seed 0, gain 1, feed-forward 1, filter 0.51 ms -> +9e-13
    rng = np.random.default_rng(seed)
    servos = Servos([PositionLoop(gain, feed_forward, filter_ms)], PERIOD_S, rows(0))
    command = 0
    for _ in range(400):
        command = int(np.clip(command + rng.integers(-900, 900), lower, upper))
        if rng.random() < 0.2:
            command = int(rng.choice((lower, upper)))
        servos.step(rows(command))
        assert lower - rounding <= servos.position[0][0] <= upper + rounding
        assert lower <= servos.feedback_pulses()[0][0] <= upper


def test_brake_freezes_the_feedback_and_sets_the_command_to_it() -> None:
    """E-stop or servo off: the axis stops dead where it is; the command becomes the feedback,
    so the next servo-on moves nothing."""
    servos = Servos([LOOP], PERIOD_S, rows(0))
    ramp(servos, 2000, 50)
    where = float(servos.position[0][0])
    held = servos.brake()
    assert held == [[round(where), 0, 0, 0, 0, 0, 0, 0]]
    assert not any(map(any, servos.moved))
    for _ in range(10):
        servos.step(held)
        assert servos.feedback_pulses() == held
        assert not any(map(any, servos.moved))


def test_groups_have_their_own_servos() -> None:
    servos = Servos([IdealServo(), LOOP], PERIOD_S, [[0] * 8, [0] * 8])
    servos.step([[100] + [0] * 7, [100] + [0] * 7])
    assert servos.position[0][0] == 100
    assert 0 < servos.position[1][0] < 100


def test_unused_axes_stay_at_zero() -> None:
    servos = Servos([LOOP], PERIOD_S, rows(0))
    ramp(servos, 100, 20)
    assert servos.position[0][1:] == [0.0] * 7
    assert math.isclose(sum(servos.moved[0][1:]), 0.0)
