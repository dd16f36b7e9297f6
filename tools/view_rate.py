"""How often ``motocell view`` sends each key: at most once a period, and always the newest
sample (``Pacing``). Pure: the caller reads the clock and passes the instant in.

Every topic the view serves comes from one key (``tools.view_channels``: a state gives each
group's joints and poses, ROBOT_STATUS and the frames), so pacing a key paces its topics, and the
topics of one state still show the same instant. A key's samples never queue behind another's:
under pressure each key is a slot holding its newest sample, so every panel shows its current
value, late by at most a period and the time to send, rather than a backlog of one busy key
(the executor's ticks, 250 a second) pushing the others' aside.
"""

from __future__ import annotations

from typing import NamedTuple


class Sample(NamedTuple):
    received_ns: int
    """When it arrived, ns since the Unix epoch: the time the view stamps on its messages."""
    key: str
    data: bytes


class Pacing:
    """At most one sample per key per ``period_ns``, the newest, with no delay for a key that
    has been quiet for a period (a status change goes out at once)."""

    def __init__(self, period_ns: int) -> None:
        if period_ns <= 0:
            raise ValueError(f"the period must be positive, not {period_ns} ns")
        self.period_ns = period_ns
        self._newest: dict[str, Sample] = {}
        """Each key's sample not yet taken."""
        self._sent_ns: dict[str, int] = {}
        """When each key's last sample was taken."""

    def offer(self, sample: Sample) -> bool:
        """Keep ``sample`` as its key's newest, replacing one not yet taken. True when the key
        had none waiting: a new instant may be due sooner than the caller's wait."""
        waiting = sample.key in self._newest
        self._newest[sample.key] = sample
        return not waiting

    def due(self, now_ns: int) -> list[Sample]:
        """The waiting sample of each key whose period has passed since its last was taken;
        each key's period starts again ``now_ns``."""
        taken = [sample for key, sample in self._newest.items() if self._due_ns(key) <= now_ns]
        for sample in taken:
            del self._newest[sample.key]
            self._sent_ns[sample.key] = now_ns
        return taken

    def next_due_ns(self) -> int | None:
        """When the earliest waiting sample may be taken; None when none waits."""
        return min((self._due_ns(key) for key in self._newest), default=None)

    def _due_ns(self, key: str) -> int:
        sent = self._sent_ns.get(key)
        return 0 if sent is None else sent + self.period_ns
