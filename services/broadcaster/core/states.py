"""What sets the state port's beat, as one table: the pacing now (``Pacing``), and for each
pacing and each thing that happens (``PacingEvent``) the pacing that follows, what is sent, and
when the next beat without a tick is due (``PACING``). ``broadcaster.Broadcaster`` holds the
pacing and consults the table on every tick and every wake-up; what it does with a step (is
the beat due, when is the next) is the same for every row.

While the executor's clock runs, snapshots follow its ticks (``shared.schedule.Schedule``). Without
ticks the state port still beats, from the last tick: every state period while the executor's
clock rests (nothing moves, so the last tick is the robot as it is) and a client is connected,
every ``AT_REST_HEARTBEAT_S`` for observers only; every ``silence_s`` when ticks stop
unannounced (an executor stalled or gone), so clients see motion_possible drop instead of
silence (docs/state-path.md, Beating without ticks).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum


class _Member(Enum):
    """Hashed by identity, as its members are singletons: ``Enum.__hash__`` runs Python, and the
    table is looked up on every tick."""

    __hash__ = object.__hash__


class Pacing(_Member):
    """What sets the state port's beat now."""

    WAITING = "no tick yet: nothing to send"
    TICKS = "the executor's ticks, a beat only if they fall silent"
    AT_REST = "the executor's clock rests: the broadcaster's own clock, from the last tick"
    SILENT = "ticks stopped unannounced: a beat every silence_s, from the last tick"


class PacingEvent(_Member):
    TICK = "a tick of the running clock"
    RESTING_TICK = "the tick the executor's clock rests after: the robot from now on"
    WAKE_WITH_CLIENTS = "woken without a tick while a state client is connected"
    WAKE_WITHOUT_CLIENTS = "woken without a tick while no state client is (observers only)"


class Sends(Enum):
    NOTHING = "nothing"
    TICK = "the tick's snapshot, whatever the schedule says"
    TICK_ON_SCHEDULE = "the tick's snapshot if it is the first at or after its due time"
    LAST_TICK_ON_BEAT = (
        "the last tick's snapshot, with the controller as it is now, once the beat is due"
    )


class Beat(_Member):
    """An interval on the broadcaster's own clock."""

    STATE_PERIOD = "the cell's state period"
    REST_HEARTBEAT = "AT_REST_HEARTBEAT_S"
    REST_SILENCE = "AT_REST_HEARTBEAT_S plus silence_s: the executor's next resting tick overdue"
    SILENCE = "silence_s: ticks unheard this long while the executor's clock runs"


class BeatFrom(Enum):
    """What the next beat is counted from."""

    NOW = "this instant"
    DUE_TIME = "the due time of the beat just sent: a steady rate, but never a burst to catch up"


@dataclass(frozen=True)
class PacingStep:
    then: Pacing
    sends: Sends
    next_beat: Beat | None
    """How long until the next beat without a tick; None: nothing until a tick."""
    counted_from: BeatFrom = BeatFrom.NOW
    due_within: Beat | None = None
    """A beat due later than this after the newest snapshot is due then: a client gets a
    state at least this often, and one that comes while only observers are paced gets one at
    once."""


_ON_TICK = PacingStep(Pacing.TICKS, Sends.TICK_ON_SCHEDULE, Beat.SILENCE)
# The executor sends its resting tick again every AT_REST_HEARTBEAT_S, and a resting
# broadcaster wakes for it (``ticks.TickSource`` sleeps parked on the tick key): that resent tick
# is the observers' beat. The broadcaster's own beat is for one that does not come (an executor
# gone at rest); at a heartbeat instead it would race the resent tick, two states a few
# milliseconds apart. A client is still paced at the state period: the (AT_REST,
# WAKE_WITH_CLIENTS) row's due_within brings the beat in.
_ON_RESTING_TICK = PacingStep(Pacing.AT_REST, Sends.TICK, Beat.REST_SILENCE)
_NOTHING_YET = PacingStep(Pacing.WAITING, Sends.NOTHING, None)
_SILENCE_FOUND = PacingStep(Pacing.SILENT, Sends.LAST_TICK_ON_BEAT, Beat.SILENCE, BeatFrom.NOW)
_SILENT_BEAT = PacingStep(Pacing.SILENT, Sends.LAST_TICK_ON_BEAT, Beat.SILENCE, BeatFrom.DUE_TIME)

PACING: dict[tuple[Pacing, PacingEvent], PacingStep] = {
    (Pacing.WAITING, PacingEvent.TICK): _ON_TICK,
    (Pacing.WAITING, PacingEvent.RESTING_TICK): _ON_RESTING_TICK,
    (Pacing.WAITING, PacingEvent.WAKE_WITH_CLIENTS): _NOTHING_YET,
    (Pacing.WAITING, PacingEvent.WAKE_WITHOUT_CLIENTS): _NOTHING_YET,
    (Pacing.TICKS, PacingEvent.TICK): _ON_TICK,
    (Pacing.TICKS, PacingEvent.RESTING_TICK): _ON_RESTING_TICK,
    # The silence bound is the beat while ticks come: passed, ticks stopped unannounced.
    (Pacing.TICKS, PacingEvent.WAKE_WITH_CLIENTS): _SILENCE_FOUND,
    (Pacing.TICKS, PacingEvent.WAKE_WITHOUT_CLIENTS): _SILENCE_FOUND,
    (Pacing.SILENT, PacingEvent.TICK): _ON_TICK,
    (Pacing.SILENT, PacingEvent.RESTING_TICK): _ON_RESTING_TICK,
    (Pacing.SILENT, PacingEvent.WAKE_WITH_CLIENTS): _SILENT_BEAT,
    (Pacing.SILENT, PacingEvent.WAKE_WITHOUT_CLIENTS): _SILENT_BEAT,
    # The first tick after a rest is the clock running again.
    (Pacing.AT_REST, PacingEvent.TICK): _ON_TICK,
    (Pacing.AT_REST, PacingEvent.RESTING_TICK): _ON_RESTING_TICK,
    (Pacing.AT_REST, PacingEvent.WAKE_WITH_CLIENTS): PacingStep(
        Pacing.AT_REST,
        Sends.LAST_TICK_ON_BEAT,
        Beat.STATE_PERIOD,
        BeatFrom.DUE_TIME,
        due_within=Beat.STATE_PERIOD,
    ),
    (Pacing.AT_REST, PacingEvent.WAKE_WITHOUT_CLIENTS): PacingStep(
        Pacing.AT_REST, Sends.LAST_TICK_ON_BEAT, Beat.REST_HEARTBEAT, BeatFrom.DUE_TIME
    ),
}
"""One step for every (pacing, event) pair: on a tick ``Broadcaster.on_tick`` takes it at once;
on a wake-up ``Broadcaster.on_wake`` takes it once the beat is due, and before that nothing
changes."""
