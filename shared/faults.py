"""The faults a controller takes on its ``controller/fault/<kind>`` queryables, in the words
an operator uses (``hold on``, ``alarm 4100 2``), and how to ask for one. ``motocell fault``
and ``motocell.testing`` both inject through here."""

from __future__ import annotations

import zenoh

from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import CommandReply, CommandRequest
from motocell.shared.bus.session import call

# kind -> accepted words (any case) -> value
SWITCHES = {
    "estop": {"on": 1, "off": 0},
    "hold": {"on": 1, "off": 0},
    "servo": {"on": 1, "off": 0},
    "remote": {"on": 1, "off": 0},
    "pfl": {"on": 1, "off": 0},
    "play": {"play": 1, "teach": 0},
    "ot889": {"on": 1, "off": 0},
}
KINDS = (*SWITCHES, "alarm", "error")
"""What ``motocell fault`` injects: a switch, or an alarm or error with its code."""
CODES = range(1, 10_000)
"""A controller numbers its alarms and errors with at most four digits (4100, 2010)."""
SUBCODES = range(10_000)


def request_for(kind: str, setting: str, subcode: int | None = None) -> CommandRequest:
    """The fault request; ValueError with one line for a setting the kind does not take."""
    word = setting.lower()
    if kind == "alarm" and subcode is not None and word != "clear":
        if subcode not in SUBCODES:
            raise ValueError(f"alarm: subcode {subcode} is not 0 to {SUBCODES[-1]}")
    elif subcode is not None:
        raise ValueError(f"{kind} {setting}: takes no subcode (got {subcode})")
    if kind in SWITCHES:
        words = SWITCHES[kind]
        if word not in words:
            raise ValueError(f"{kind}: expected {' or '.join(words)}, got {setting!r}")
        return CommandRequest(value=words[word])
    if word == "clear":
        return CommandRequest(value=0)
    try:
        code = int(setting)
    except ValueError:
        raise ValueError(f"{kind}: expected a code or 'clear', got {setting!r}") from None
    if code not in CODES:
        raise ValueError(f"{kind}: code {code} is not 1 to {CODES[-1]}")
    return CommandRequest(value=1, args=[code, subcode or 0])


def inject(
    session: zenoh.Session, cell: str, kind: str, request: CommandRequest
) -> CommandReply | None:
    """Ask ``cell``'s controller to apply the fault (``session`` joined as its operator); its
    reply, or None when no controller answered in time."""
    return call(session, CellKeys(cell).controller_fault(kind), request, timeout=3.0)
