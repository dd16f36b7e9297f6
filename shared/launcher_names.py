"""What a launcher's processes know it by: the variable that names its pid to its children, the
module its warm parent runs, and the command that starts a launcher with room for the command
lines of the services it forks (docs/startup.md).

Apart from ``service_names`` because a launcher's first line, and ``motocell up``'s, need these
and nothing more: ``service_names`` brings ``dataclasses`` and ``typing``.
"""

import sys

PARENT_PID_ENV = "MOTOCELL_PARENT_PID"
"""Set by ``motocell up`` for its children: they stop when that process goes away."""
WARM_PARENT_MODULE = "motocell.services.launcher.zygote"
"""The launcher's warm parent, which the services are forked from (docs/startup.md): a process
of the cell beside them, but no service."""
LAUNCHER_MODULE = "motocell.services.launcher"
ROOM_OPTION = "motocell_room"
"""An interpreter option (``-X``, which ``sys.argv`` does not show) whose value is only room: a
forked service writes its own command line over its launcher's
(``command_line.rewrite_command_line``), and a cell's longest, with its paths, is a few hundred
bytes."""
ROOM = 8192


def launcher_command() -> list[str]:
    """``python -m motocell.services.launcher`` with the room its forks write their command
    lines into; its arguments follow."""
    return with_room([sys.executable, "-m", LAUNCHER_MODULE])


def with_room(command: list[str]) -> list[str]:
    """An interpreter's ``command`` (as ``sys.orig_argv``: the interpreter, its options, what
    it runs and its arguments) with the room as its first option."""
    return [sys.executable, "-X", f"{ROOM_OPTION}={' ' * ROOM}", *command[1:]]


def without_room(command: list[str]) -> list[str]:
    """``command`` as it was before ``with_room``."""
    room = f"{ROOM_OPTION}="
    kept = list(command)
    for index, word in enumerate(command):
        if index and word.startswith(room) and command[index - 1] == "-X":
            del kept[index - 1 : index + 1]
            break
    return kept
