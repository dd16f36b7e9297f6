"""The signals that stop a motocell process, SIGINT and SIGTERM, held from a command's first
line until its handlers are in place (``shared.service.stop_on_signals`` takes them then).

Held, one that arrives while Zenoh and the modules load waits in the kernel instead of landing
in an import, where Python may report it as "Exception ignored" and go on; and an ignored
SIGINT stays pending (Linux discards only unblocked ones), so SIGINT stops motocell whatever
disposition it inherits: a script starts ``motocell up &`` with SIGINT ignored. Imports nothing
of ours, so that holding costs nothing before it.
"""

from __future__ import annotations

import signal

STOP_SIGNALS = frozenset({signal.SIGINT, signal.SIGTERM})


def hold_stop_signals() -> None:
    """Block SIGINT and SIGTERM in this thread (and so in every thread it starts), and take an
    inherited ignore of SIGINT back to Python's own handler for when they are released."""
    signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


def release_stop_signals() -> None:
    """Deliver what was held, and any that come later, to the handlers now in place."""
    signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP_SIGNALS)


def drop_held_stop_signals() -> None:
    """Discard a SIGINT or SIGTERM held and not yet delivered, the handlers kept: setting a
    signal's action to ignore discards it even while blocked (POSIX, and Linux's
    ``do_sigaction``). For a process forked while they were held, which is not who they were
    meant for."""
    for sig in STOP_SIGNALS:
        signal.signal(sig, signal.signal(sig, signal.SIG_IGN))
