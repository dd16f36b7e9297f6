"""When the executor's clock rests: it stops ticking once nothing has been queued, owed or
settling for ``REST_AFTER_NS``, and runs again when motion is asked for. Pure."""

from __future__ import annotations

REST_AFTER_NS = 1_000_000_000
"""How long the clock keeps ticking with nothing to do before it rests: a client between two
points of one trajectory (motoman_driver streams several a second) keeps it running."""


def next_on_grid(origin_ns: int, period_ns: int, now_ns: int) -> int:
    """The first deadline at or after ``now_ns`` on the clock's grid (``origin_ns`` plus whole
    periods): a clock that rested resumes in the phase it had, so the first increment of a
    trajectory lands on the tick boundary it would have had if the clock had never stopped."""
    periods = max(0, -(-(now_ns - origin_ns) // period_ns))
    return origin_ns + periods * period_ns


class Resting:
    """Whether the clock rests, from what each tick found (``after_tick``) and from what asks
    for motion (``wake``)."""

    def __init__(self) -> None:
        self.resting = False
        """The clock stopped: nothing queued, owed or settling for ``REST_AFTER_NS``."""
        self._quiet_since_ns: int | None = None

    def wake(self) -> bool:
        """Motion is asked for: a resting clock runs again. Whether it was resting."""
        if not self.resting:
            return False
        self.resting = False
        return True

    def after_tick(self, quiet: bool, now_ns: int) -> bool:
        """A tick at ``now_ns`` found nothing to do (``quiet``) or something. Whether the
        clock rests from now on."""
        if not quiet:
            self._quiet_since_ns = None
        elif self._quiet_since_ns is None:
            self._quiet_since_ns = now_ns
        elif now_ns - self._quiet_since_ns >= REST_AFTER_NS:
            self.resting = True
            self._quiet_since_ns = None
            return True
        return False
