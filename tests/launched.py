"""A launcher a test starts by its command line (``motocell up`` with options of its own), on
ports picked free and picked again when one was taken between the pick and the launcher's
bind (``testing.ports.on_free_port``)."""

from __future__ import annotations

import subprocess
from collections.abc import Callable, Mapping
from pathlib import Path

from motocell.testing.ports import HOST, ended, on_free_port
from motocell.testing.processes import connectable, wait_until
from motocell.testing.running_cell import LAUNCHER, START_TIMEOUT_S

CommandOn = Callable[[int, int], list[str]]
"""A launcher's command on a port base (its three TCP ports) and its router's port."""


def named(name: str) -> CommandOn:
    """``motocell up --name NAME`` (the default cell) on the ports given, its own router."""

    def command_on(port_base: int, router_port: int) -> list[str]:
        listen = f"tcp/{HOST}:{router_port}"
        return [*LAUNCHER, "--port-base", str(port_base), "--zenoh-listen", listen, "--name", name]

    return command_on


def launched(
    command_on: CommandOn, env: Mapping[str, str], log: Path
) -> tuple[subprocess.Popen[bytes], int]:
    """The launcher ``command_on`` gives, its output in ``log``, once its motion port listens,
    and its port base. AssertionError with its output if it exits for another reason than a
    port taken meanwhile."""

    def started(port_base: int) -> tuple[subprocess.Popen[bytes], int]:
        # Four ports in a row: motion, state, I/O, then the router's.
        with log.open("wb") as out:
            process = subprocess.Popen(
                command_on(port_base, port_base + 3), env=dict(env), stdout=out, stderr=out
            )
        wait_until(
            lambda: process.poll() is not None or connectable(HOST, port_base),
            START_TIMEOUT_S,
            "the launcher's motion port to listen",
        )
        if process.poll() is not None:
            said = log.read_text(errors="replace")
            raise ended("the launcher", process.returncode, said)
        return process, port_base

    return on_free_port(started, count=4)
