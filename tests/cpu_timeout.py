"""pytest-timeout's bound in CPU seconds, not wall seconds, for the properties (Hypothesis tests).

A property runs its examples in this process, computing: it starts no process and waits on
nothing. Its wall time is its CPU time times the machine's load: the deep profile's 300
examples of the costliest ones took 10 to 25 CPU seconds under coverage,
which at load 20 on two cores is past pytest-timeout's 120 s, though nothing hangs. What can go
wrong in a property is a loop that does not end, and that spends CPU: so for a property the
timeout (``timeout`` in pyproject.toml, or the test's mark) counts this process's CPU time
(``ITIMER_PROF``: every thread's, user and system), which the neighbours' load does not change.
Every other test keeps pytest-timeout's wall-clock bound: what it waits for costs no CPU.

It works through pytest-timeout's own hooks, so the timeout and its marks keep their meaning.
With no signal to use (a run outside the main thread), the property keeps pytest-timeout's.
"""

from __future__ import annotations

import signal
import threading
from types import FrameType
from typing import Any

import pytest
from hypothesis import is_hypothesis_test

_CANCEL = pytest.StashKey[Any]()


class CpuTimeoutError(BaseException):
    """A property over its CPU time. Not an ``Exception``, nor ``pytest.fail``'s: Hypothesis
    would take either for the property failing and shrink the example, running again what
    does not end."""


def is_property(item: pytest.Item) -> bool:
    return isinstance(item, pytest.Function) and is_hypothesis_test(item.obj)


class CpuTimeout:
    """The plugin: pytest-timeout's timer, in CPU seconds, for the properties."""

    @pytest.hookimpl(optionalhook=True, tryfirst=True)
    def pytest_timeout_set_timer(self, item: pytest.Item, settings: Any) -> bool | None:
        if not is_property(item) or threading.current_thread() is not threading.main_thread():
            return None
        limit: float = settings.timeout

        def expired(signum: int, frame: FrameType | None) -> None:
            __tracebackhide__ = True
            raise CpuTimeoutError(f"the property spent more than {limit:g} s of CPU time")

        previous = signal.signal(signal.SIGPROF, expired)
        signal.setitimer(signal.ITIMER_PROF, limit)

        def cancel() -> None:
            signal.setitimer(signal.ITIMER_PROF, 0)
            signal.signal(signal.SIGPROF, previous)

        item.stash[_CANCEL] = cancel
        return True

    @pytest.hookimpl(optionalhook=True, tryfirst=True)
    def pytest_timeout_cancel_timer(self, item: pytest.Item) -> bool | None:
        cancel = item.stash.get(_CANCEL, None)
        if cancel is None:
            return None
        del item.stash[_CANCEL]
        cancel()
        return True
