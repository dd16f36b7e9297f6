"""Start a command as a terminal starts a foreground job, whatever this process inherited.

A terminal's foreground job has SIGINT and SIGQUIT at their defaults. A test run started in the
background (``nohup ... &``, a CI agent's non-interactive shell) inherits them ignored, and an
ignored signal stays ignored across exec: Python then installs no KeyboardInterrupt handler and
bash cannot trap it, so a test of what Ctrl-C does would test nothing of the kind. Found when a
full run started with ``&`` failed exactly the two tests that send a Ctrl-C to a plain Python
and to a bash script (the motocell commands set their own handlers and passed).
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

FOREGROUND = (
    sys.executable,
    "-c",
    "import os, signal, sys\n"
    "for name in ('SIGINT', 'SIGQUIT'):\n"
    "    signal.signal(getattr(signal, name), signal.SIG_DFL)\n"
    "os.execvp(sys.argv[1], sys.argv[1:])",
)


def as_a_terminal_starts(command: Sequence[str]) -> list[str]:
    """``command`` with SIGINT and SIGQUIT at their defaults (exec keeps a default)."""
    return [*FOREGROUND, *command]
