"""When the face publishes MotoROS2's topics: the pacing table ``PACING``.

MotoROS2 publishes ``joint_states`` and ``robot_status`` every
``controller_status_monitor_period`` (10 ms) whether the robot moves or not, and MoveIt 2
counts a robot whose joint states stop as unknown. The cell's ``state`` comes at the cell's
state period while the executor's clock runs, and once a second while it rests. So:

- *following*: a state sample is published as it arrives, on the face's period
  (``shared.schedule.Schedule``: the first sample at or after each due time), so its age is the
  cell's, not a timer's;
- *holding*: no sample for one and a half periods (the clock rests): the newest one is
  published again every period, stamped now, as MotoROS2 reads an idle controller;
- *quiet*: no sample yet, or none for ``SILENCE`` (the cell's state is gone: the broadcaster or
  the router): nothing is published, so a client sees stale joint states rather than a
  position nobody measured. The face then waits for a sample without waking.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum


class Pacing(Enum):
    QUIET = "nothing to publish: no sample yet, or the cell's state stopped"
    FOLLOWING = "publishing samples as they come"
    HOLDING = "publishing the newest sample again every period"


class PacingEvent(Enum):
    SAMPLE_DUE = "a sample, the first at or after the due time"
    SAMPLE_EARLY = "a sample before the due time"
    DUE = "woken at the deadline, a sample heard within SILENCE"
    SILENCE = "woken, no sample heard within SILENCE (or ever)"


class Publish(Enum):
    NOTHING = "nothing"
    SAMPLE = "the sample that came"
    NEWEST_AGAIN = "the newest sample, stamped now"


class Wake(Enum):
    """When the face must wake without a sample."""

    HOLD_AFTER = "one and a half periods after this sample"
    PERIOD = "one period after the last deadline"
    UNCHANGED = "as before"
    NEVER = "only for a sample"


@dataclass(frozen=True)
class PacingStep:
    then: Pacing
    publish: Publish
    wake: Wake


class ImpossibleEventError(RuntimeError):
    """An event its pacing cannot have (a ``None`` row): a bug in the face."""


_FOLLOW = PacingStep(Pacing.FOLLOWING, Publish.SAMPLE, Wake.HOLD_AFTER)
_KEEP = PacingStep(Pacing.FOLLOWING, Publish.NOTHING, Wake.UNCHANGED)
_HOLD = PacingStep(Pacing.HOLDING, Publish.NEWEST_AGAIN, Wake.PERIOD)
_QUIET = PacingStep(Pacing.QUIET, Publish.NOTHING, Wake.NEVER)

PACING: dict[tuple[Pacing, PacingEvent], PacingStep | None] = {
    (Pacing.QUIET, PacingEvent.SAMPLE_DUE): _FOLLOW,
    # A broadcaster that came back sends its resting tick again, an old one: news all the same.
    (Pacing.QUIET, PacingEvent.SAMPLE_EARLY): _FOLLOW,
    # Quiet, the face wakes only for a sample or at stop, and no sample is recent.
    (Pacing.QUIET, PacingEvent.DUE): None,
    (Pacing.QUIET, PacingEvent.SILENCE): _QUIET,
    (Pacing.FOLLOWING, PacingEvent.SAMPLE_DUE): _FOLLOW,
    (Pacing.FOLLOWING, PacingEvent.SAMPLE_EARLY): _KEEP,
    (Pacing.FOLLOWING, PacingEvent.DUE): _HOLD,
    (Pacing.FOLLOWING, PacingEvent.SILENCE): _QUIET,
    # A sample while holding is published at once: the first news after a rest.
    (Pacing.HOLDING, PacingEvent.SAMPLE_DUE): _FOLLOW,
    (Pacing.HOLDING, PacingEvent.SAMPLE_EARLY): _FOLLOW,
    (Pacing.HOLDING, PacingEvent.DUE): _HOLD,
    (Pacing.HOLDING, PacingEvent.SILENCE): _QUIET,
}
