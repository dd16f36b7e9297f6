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
forked service writes its own command line over its launcher's (``zygote.rewrite_command_line``),
and a cell's longest, with its paths, is a few hundred bytes."""
ROOM = 8192


def launcher_command() -> list[str]:
    """``python -m motocell.services.launcher`` with the room its forks write their command
    lines into; its arguments follow."""
    return [sys.executable, "-X", f"{ROOM_OPTION}={' ' * ROOM}", "-m", LAUNCHER_MODULE]
