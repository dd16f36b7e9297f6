"""When a child that died comes back (``states.RESTARTS``), with the time passed in."""

from __future__ import annotations

from motocell.services.launcher.core.states import RESTARTS, ChildState, Exit, Restart
from motocell.shared.config import EXIT_CONFIG

RESTART_DELAY_S = 1.0


class RestartPolicy:
    """A dead child is restarted ``delay_s`` after it was found dead (``states``)."""

    def __init__(self, delay_s: float = RESTART_DELAY_S) -> None:
        self.delay_s = delay_s
        self._restart_at: dict[str, float] = {}

    def dead(self, name: str, now: float, returncode: int | None = None) -> Restart:
        """What to do about child ``name``, found dead at ``now`` (seconds, any clock) with
        ``returncode``."""
        how = Exit.CANNOT_START if returncode == EXIT_CONFIG else Exit.FAILED
        restart = RESTARTS[(self.state(name, now), how)]
        if restart is Restart.NOTICED:
            self._restart_at[name] = now + self.delay_s
        elif restart is Restart.NOW:
            del self._restart_at[name]
        return restart

    def state(self, name: str, now: float) -> ChildState:
        """Where child ``name``'s restart stands at ``now``."""
        restart_at = self._restart_at.get(name)
        if restart_at is None:
            return ChildState.RUNNING
        return ChildState.RESTART_PENDING if now < restart_at else ChildState.RESTART_DUE

    def next_restart(self) -> float | None:
        """When the earliest restart waiting is due (None: none waits)."""
        return min(self._restart_at.values(), default=None)
