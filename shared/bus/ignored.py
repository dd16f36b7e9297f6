"""Samples a subscriber ignores: counted, and logged at most once per interval.

Anyone allowed to write a key can send anything on it: bytes that do not decode, another key's
payload, a key with a group the cell does not have. A subscriber ignores such a sample and goes
on; it must never raise (a service's thread would die with it) nor log every one (a flood of
them would flood the log, and the disk under it). So each goes through ``IgnoredSamples.note``:
the first is logged at once, those that follow within ``interval_s`` only counted, and the first
one after that is logged with how many were ignored in between.

One tally per process (``IGNORED``, which ``note`` notes in), shared by every subscriber in
it: the limit is on the log, whichever key the samples come on. It takes its lock only for a
sample being ignored, so a good sample costs nothing here.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import TypeVar

import msgspec

from motocell.shared.bus.schemas import Decoder

INTERVAL_S = 10.0
"""At most one line per this many seconds, whatever arrives."""

UNDECODABLE = "undecodable sample"
"""What ``decoded_payload`` notes a payload that does not decode as."""

T = TypeVar("T")

log = logging.getLogger("bus")


class IgnoredSamples:
    """The count of ignored samples, and the rate-limited log line about them."""

    def __init__(
        self,
        interval_s: float = INTERVAL_S,
        clock: Callable[[], float] = time.monotonic,
        logger: logging.Logger = log,
    ) -> None:
        self._interval_s = interval_s
        self._clock = clock
        self._log = logger
        self._lock = threading.Lock()
        self._total = 0
        self._unlogged = 0
        """Ignored since the last line, not named in one."""
        self._logged_at: float | None = None

    @property
    def total(self) -> int:
        """Every sample ignored so far."""
        with self._lock:
            return self._total

    def note(self, key: str, what: str) -> None:
        """A sample on ``key`` was ignored because it is ``what`` (``"undecodable sample"``,
        ``"point for no group of this cell"``)."""
        with self._lock:
            self._total += 1
            now = self._clock()
            if self._logged_at is not None and now - self._logged_at < self._interval_s:
                self._unlogged += 1
                return
            unlogged, self._unlogged, self._logged_at = self._unlogged, 0, now
        if unlogged:
            self._log.warning(
                "%s on %s ignored (and %d more since the last such line)",
                what,
                key,
                unlogged,
            )
        else:
            self._log.warning("%s on %s ignored", what, key)


IGNORED = IgnoredSamples()
"""This process's tally."""


def decoded_payload(
    payload: bytes | None, decoder: Decoder[T], key: str, ignored: IgnoredSamples | None = None
) -> T | None:
    """``payload`` decoded; None for no payload, an empty one (a doorbell), or one that does not
    decode, which is noted in ``ignored`` (this process's tally unless said): a peer's bad
    sample must not stop the thread reading it, nor a flood of them flood the log."""
    if not payload:
        return None
    try:
        return decoder.decode(payload)
    except msgspec.DecodeError:
        (IGNORED if ignored is None else ignored).note(key, UNDECODABLE)
        return None


def note(key: str, what: str) -> None:
    """``IgnoredSamples.note`` on this process's tally."""
    IGNORED.note(key, what)
