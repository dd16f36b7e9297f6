"""``motocell up``: a whole cell as child processes on this machine, in the foreground.

The launcher runs a Zenoh router on loopback that every service connects to (multicast
scouting stays off). The first cell on a machine takes the well-known port 7447, so observers
find it with no arguments; a later cell runs its router on a free port and links it to 7447,
so one observer sees every cell. A child that dies is logged and restarted; meanwhile the
controller sees its liveliness token gone and the cell answers NOT_READY.
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass

import zenoh

from shared.bus.session import open_session
from shared.config import Cell, ConfigError, load_cell
from shared.ports import free_port, port_free
from shared.service import PARENT_PID_ENV

log = logging.getLogger("motocell")

WELL_KNOWN_PORT = 7447
STOP_GRACE_S = 4.0
"""SIGTERM, then SIGKILL after this; the whole stop stays within 5 s."""
RESTART_DELAY_S = 1.0


@dataclass
class Child:
    name: str
    argv: list[str]
    process: subprocess.Popen[bytes] | None = None
    restarts: int = 0
    restart_at: float = 0.0

    def start(self) -> None:
        # The child arranges to get SIGTERM if the launcher dies (shared.service), so no
        # half cell outlives a killed launcher.
        env = {**os.environ, PARENT_PID_ENV: str(os.getpid())}
        self.process = subprocess.Popen(self.argv, env=env)

    def alive(self) -> bool:
        return self.process is not None and self.process.poll() is None


def open_hub(listen: list[str], connect: list[str]) -> tuple[zenoh.Session, str]:
    """The cell's router. Returns it and the endpoint its services should connect to."""
    if not listen:
        if port_free(WELL_KNOWN_PORT):
            listen = [f"tcp/127.0.0.1:{WELL_KNOWN_PORT}"]
        else:
            listen = [f"tcp/127.0.0.1:{free_port()}"]
            connect = connect or [f"tcp/127.0.0.1:{WELL_KNOWN_PORT}"]
    # Not waiting: a router retries an absent link in the background.
    session = open_session("router", connect, listen, wait=False)
    return session, listen[0]


def child_commands(cell: Cell, args: argparse.Namespace, endpoint: str) -> list[Child]:
    common = ["--zenoh-connect", endpoint]
    if args.config:
        common += ["--config", args.config]
    if args.zenoh_mode:
        common += ["--zenoh-mode", args.zenoh_mode]
    python = [sys.executable, "-m"]
    children = [
        Child("controller", [*python, "services.controller", *common]),
        Child("executor", [*python, "services.executor", *common]),
        Child("broadcaster", [*python, "services.broadcaster", *common]),
    ]
    children += [
        Child(
            f"interpolator/{g.index}",
            [*python, "services.interpolator", *common, "--group", str(g.index)],
        )
        for g in cell.groups
    ]
    gateway = [*python, "services.gateway", *common]
    if args.host:
        gateway += ["--host", args.host]
    if args.port_base:
        gateway += ["--port-base", str(args.port_base)]
    if args.byte_order:
        gateway += ["--byte-order", args.byte_order]
    children.append(Child("gateway", gateway))
    skipped = set(args.skip or ())
    unknown = skipped - {child.name for child in children}
    if unknown:
        raise ValueError(
            f"--skip {', '.join(sorted(unknown))}: no such service in this cell "
            f"(services: {', '.join(child.name for child in children)})"
        )
    return [child for child in children if child.name not in skipped]


def supervise(children: list[Child], stop: threading.Event) -> None:
    for child in children:
        child.start()
    while not stop.wait(0.2):
        now = time.monotonic()
        for child in children:
            if child.alive():
                continue
            if child.restart_at == 0.0:
                code = child.process.returncode if child.process else None
                log.error(
                    "%s exited (code %s); restarting in %.0f s; the cell is NOT_READY "
                    "until it is back",
                    child.name,
                    code,
                    RESTART_DELAY_S,
                )
                child.restart_at = now + RESTART_DELAY_S
            elif now >= child.restart_at:
                child.restarts += 1
                child.restart_at = 0.0
                child.start()


def stop_children(children: list[Child]) -> None:
    running = [c for c in children if c.alive()]
    for child in running:
        assert child.process is not None
        child.process.send_signal(signal.SIGTERM)
    deadline = time.monotonic() + STOP_GRACE_S
    for child in running:
        assert child.process is not None
        try:
            child.process.wait(timeout=max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            log.warning("%s did not stop in time; killing it", child.name)
            child.process.kill()
            child.process.wait()


def up(args: argparse.Namespace) -> int:
    try:
        cell = load_cell(args.config)
    except ConfigError as exc:
        print(f"motocell up: {exc}", file=sys.stderr)
        return 2
    stop = threading.Event()

    def on_signal(signum: int, _frame: object) -> None:
        stop.set()

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    hub: zenoh.Session | None = None
    if args.zenoh_connect:
        endpoint = args.zenoh_connect[0]
    else:
        hub, endpoint = open_hub(args.zenoh_listen, [])
    try:
        children = child_commands(cell, args, endpoint)
    except ValueError as exc:
        print(f"motocell up: {exc}", file=sys.stderr)
        return 2
    host = args.host or cell.host
    port = args.port_base or cell.port_base
    log.info(
        "cell %s: %d group(s), ports %s:%d-%d, Zenoh at %s",
        cell.name,
        len(cell.groups),
        host,
        port,
        port + 2,
        endpoint,
    )
    try:
        supervise(children, stop)
    finally:
        stop_children(children)
        if hub is not None:
            hub.close()
        log.info("cell %s stopped", cell.name)
    return 0


def router(args: argparse.Namespace) -> int:
    """``motocell router``: a Zenoh router in this process until SIGINT/SIGTERM."""
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    listen = args.listen or [f"tcp/127.0.0.1:{WELL_KNOWN_PORT}"]
    session = open_session("router", args.connect, listen)
    log.info("Zenoh router listening on %s", ", ".join(listen))
    stop.wait()
    session.close()
    return 0
