"""``ros2_call.py`` driven from a test: a ROS 2 client of a cell's face in a process of its own
(rclpy and DDS stay out of pytest's), on this host only, asked one line at a time."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

from motocell.shared.ros2.interfaces import ensure

CALLER = Path(__file__).with_name("ros2_call.py")
ANSWER_TIMEOUT_S = 90.0
"""For the caller's start and each answer (its own deadlines are 30 s): a bound for a hang."""


class Caller:
    """``ros2_call.py``, asked one line at a time."""

    def __init__(self, domain: int, namespace: str) -> None:
        interfaces, _ = ensure()
        env = interfaces.environment({**os.environ, "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"})
        self.process = subprocess.Popen(
            [sys.executable, str(CALLER), str(domain), namespace],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            env=env,
        )
        assert self._line() == "ready"

    def _line(self) -> str:
        assert self.process.stdout is not None
        line = self.process.stdout.readline()
        assert line, "the caller ended"
        return line.strip()

    def ask(self, *words: str) -> Any:
        assert self.process.stdin is not None
        self.process.stdin.write(" ".join(words) + "\n")
        self.process.stdin.flush()
        return json.loads(self._line())

    def close(self) -> None:
        if self.process.stdin is not None:
            self.process.stdin.close()
        try:
            self.process.wait(timeout=ANSWER_TIMEOUT_S)
        finally:
            if self.process.poll() is None:
                self.process.kill()
                self.process.wait()
            if self.process.stdout is not None:
                self.process.stdout.close()
