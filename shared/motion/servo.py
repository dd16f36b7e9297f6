"""How each axis's feedback follows its commanded position: a servo model per axis, pure Python.

The executor applies one increment per axis per period to the commanded position (what MotoROS
reads with ``mpGetPulsePos``); the motion system's servo drives the motor after it, and the
encoder (``mpGetFBPulsePos``) lags behind. ``Servos`` is that servo for every axis of a cell, one
row per group, one column per Motoman axis, stepped once per period. docs/servo.md derives the
model, its defaults and each stop's profile.

A ``position_loop`` axis, per period ``T`` (``c`` the commanded pulses after the period's
increment):

    s_k = a_f * s_(k-1) + (1 - a_f) * c_k      command filter, a_f = exp(-T / filter)
    l_k = a_p * l_(k-1) + (1 - a_p) * s_k      the loop's lag,  a_p = exp(-gain * T)
    y_k = ff * s_k + (1 - ff) * l_k            feedback

The last two lines are the exact solution of a position loop with velocity feed-forward,
``y' = ff * s' + gain * (s - y)``, for a command that steps at the start of each period. Every
stage is a weighted average of earlier inputs with non-negative weights that sum to 1, so the
feedback is always within the range of the commanded positions so far (to the rounding of
doubles, about 1e-12 pulses, which the encoder's whole pulses never show): it never overshoots a
command, never passes a joint limit the command respects, and after a stop it comes to rest on
the frozen command from behind. Once every stage of an axis whose command did not move is
within half a pulse of it, the axis snaps onto the command, so a robot at rest reads exactly
its commanded pulses (final error 0).

An ``ideal`` axis has ``a_f = a_p = 0`` and ``ff = 1``: every stage is the command, exactly.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from motocell.shared.config import IdealServo, ServoSettings

SNAP_PULSES = 0.5
"""An axis at rest whose stages are all closer than this to the command reads the command: the
encoder's resolution is one pulse, so the rest of an exponential tail is below it."""


def coefficients(settings: ServoSettings, period_s: float) -> tuple[float, float, float]:
    """(a_f, a_p, ff) of one axis's servo for a period of ``period_s``."""
    if isinstance(settings, IdealServo):
        return 0.0, 0.0, 1.0
    a_filter = math.exp(-period_s * 1e3 / settings.filter_ms) if settings.filter_ms > 0 else 0.0
    return a_filter, math.exp(-settings.gain * period_s), settings.feed_forward


def ramp_following_error(
    settings: ServoSettings, period_s: float, pulses_per_period: float
) -> float:
    """The steady following error (pulses) of a command moving ``pulses_per_period`` every
    period, as ``Servos`` computes it: each first-order stage lags a ramp by
    ``step * a / (1 - a)``, and the loop's stage counts with its weight ``1 - ff``."""
    a_filter, a_loop, feed_forward = coefficients(settings, period_s)
    return pulses_per_period * (
        a_filter / (1.0 - a_filter) + (1.0 - feed_forward) * a_loop / (1.0 - a_loop)
    )


class Servos:
    """The servos of a cell: row g is group g, column i its Motoman axis i (unused axes are
    commanded 0 and stay there). ``step`` once per period with the commanded pulses; read
    ``feedback_pulses`` (what the encoder shows) and ``moved`` (what the feedback moved in the
    last period, in pulses: its velocity times the period).

    Plain Python floats, one list per group: a cell has at most 4 x 8 axes, and numpy's call
    overhead on arrays that small cost more than the arithmetic, which is the same IEEE double
    arithmetic in the same order (docs/realtime.md, "The tick's cost"). An axis settled on an
    unchanged command is skipped."""

    def __init__(
        self,
        settings: Sequence[ServoSettings],
        period_s: float,
        command: Sequence[Sequence[int]],
    ) -> None:
        """``settings`` per group; ``command``: the commanded pulses the axes rest at."""
        self._coefficients = [coefficients(s, period_s) for s in settings]
        self.command: list[list[float]] = [[float(c) for c in row] for row in command]
        self.filtered = [list(row) for row in self.command]
        self.lagged = [list(row) for row in self.command]
        self.position = [list(row) for row in self.command]
        """The feedback, to a fraction of a pulse."""
        self.moved: list[list[float]] = [[0.0] * len(row) for row in self.command]
        self._at_rest = True

    def step(self, command: Sequence[Sequence[int]]) -> None:
        """One period: the feedback moves toward ``command`` (the commanded pulses after this
        period's increments)."""
        at_rest = True
        for group, row in enumerate(command):
            if not self._step_group(group, row):
                at_rest = False
        self._at_rest = at_rest

    def _step_group(self, group: int, row: Sequence[int]) -> bool:
        """One period of ``group``'s axes; whether every one is settled on its command."""
        a_filter, a_loop, feed_forward = self._coefficients[group]
        b_filter, b_loop, feed_back = 1.0 - a_filter, 1.0 - a_loop, 1.0 - feed_forward
        commanded, filtered = self.command[group], self.filtered[group]
        lagged, position, moved = self.lagged[group], self.position[group], self.moved[group]
        settled_all = True
        for axis, pulses in enumerate(row):
            target = float(pulses)
            still = target == commanded[axis]
            if still and filtered[axis] == lagged[axis] == position[axis] == target:
                moved[axis] = 0.0  # settled: stepping changes nothing
                continue
            commanded[axis] = target
            stage_filter = filtered[axis] * a_filter + b_filter * target
            stage_loop = lagged[axis] * a_loop + b_loop * stage_filter
            feedback = feed_forward * stage_filter + feed_back * stage_loop
            if (
                still
                and abs(stage_filter - target) < SNAP_PULSES
                and abs(stage_loop - target) < SNAP_PULSES
            ):
                stage_filter = stage_loop = feedback = target
            else:
                settled_all = False
            filtered[axis], lagged[axis] = stage_filter, stage_loop
            moved[axis] = feedback - position[axis]
            position[axis] = feedback
        return settled_all

    def brake(self) -> list[list[int]]:
        """Servo off (E-stop, STOP_SERVOS, eco): every axis stops where its feedback is, and the
        commanded position becomes the feedback, so switching the servo on again moves
        nothing. Returns the commanded pulses now."""
        held = self.feedback_pulses()
        for stage in (self.command, self.filtered, self.lagged, self.position):
            stage[:] = [[float(p) for p in row] for row in held]
        self.moved = [[0.0] * len(row) for row in held]
        self._at_rest = True
        return held

    @property
    def at_rest(self) -> bool:
        """Every axis settled exactly on its command: stepping again would change nothing."""
        return self._at_rest

    def feedback_pulses(self) -> list[list[int]]:
        """The encoder's whole pulses (rounded half to even, as the encoder model always
        was)."""
        return [[round(p) for p in row] for row in self.position]
