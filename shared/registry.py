"""The cells running on this machine for this user: where each one's bus and ports are.

``motocell up`` registers its cell under its name and removes the entry when it stops; a tool
asked about a cell finds its Zenoh endpoint and credentials here instead of guessing a port.
An entry whose launcher is gone (killed, machine rebooted) is stale and ignored.

The credentials ``motocell up`` writes for a cell (``credentials_dir``) live as long as the
cell: its launcher removes them with its entry when it stops, and a registration removes those
of every cell whose launcher is gone (killed: it could not remove its own). They are new at
every start, so nothing is lost; credentials a user gives (``--credentials``) are never here.

The directory is ``$MOTOCELL_RUNTIME_DIR``, else ``$XDG_RUNTIME_DIR/motocell``, else
``~/.local/state/motocell``; tests point it at a directory of their own.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import shutil
from collections.abc import Iterator
from pathlib import Path

import msgspec

ENV = "MOTOCELL_RUNTIME_DIR"


class CellEntry(msgspec.Struct, frozen=True, kw_only=True):
    name: str
    pid: int
    """The launcher's process."""
    host: str
    port_base: int
    zenoh_endpoint: str
    credentials: str = ""
    """The cell's credentials directory; empty for an open bus."""
    config: str = ""
    """The cell file it runs, as any process finds it: a file by its absolute path, a sample
    cell by its name; empty for the default cell (``motocell view`` draws the cell from it)."""

    def describe(self) -> str:
        return (
            f"{self.name} (pid {self.pid}, ports {self.host}:{self.port_base}-"
            f"{self.port_base + 2}, Zenoh {self.zenoh_endpoint})"
        )


class CellNameTakenError(Exception):
    def __init__(self, running: CellEntry) -> None:
        super().__init__(f"a cell named {running.name} is already running: {running.describe()}")
        self.running = running


class NoSuchCellError(LookupError):
    """Names the cells that are running instead."""


def runtime_dir() -> Path:
    if os.environ.get(ENV):
        return Path(os.environ[ENV])
    if os.environ.get("XDG_RUNTIME_DIR"):
        return Path(os.environ["XDG_RUNTIME_DIR"]) / "motocell"
    return Path.home() / ".local" / "state" / "motocell"


def credentials_dir(name: str, runtime: Path | None = None) -> Path:
    """Where ``motocell up`` keeps cell ``name``'s credentials: private to this user, new at
    every start of the cell, gone when it stops. ``runtime``: another registry directory than
    this process's."""
    return _credentials_root(runtime) / name


def _credentials_root(runtime: Path | None = None) -> Path:
    return (runtime or runtime_dir()) / "credentials"


def _cells_dir() -> Path:
    directory = runtime_dir() / "cells"
    directory.mkdir(parents=True, exist_ok=True, mode=0o700)
    return directory


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _read(path: Path) -> CellEntry | None:
    try:
        return msgspec.json.decode(path.read_bytes(), type=CellEntry)
    except (OSError, msgspec.ValidationError, msgspec.DecodeError):
        return None


def register(entry: CellEntry) -> None:
    """Claim ``entry.name`` on this machine; CellNameTakenError if a live cell holds it.

    Check and claim happen under one lock on the registry, so of two launchers starting
    together exactly one wins; the entry is renamed into place whole, so nobody reads half.
    """
    directory = _cells_dir()
    path = directory / f"{entry.name}.json"
    with _locked(directory):
        held = _read(path)
        if held is not None and held.pid != entry.pid and _alive(held.pid):
            raise CellNameTakenError(held)
        draft = directory / f".{entry.name}.draft"
        _write_private(draft, msgspec.json.encode(entry))
        draft.replace(path)
        _remove_stale_credentials(directory)


def _remove_stale_credentials(cells: Path) -> None:
    """The credentials folders of cells that no longer run; under the registry's lock, so a
    cell registering meanwhile keeps its own."""
    folder = _credentials_root()
    if not folder.is_dir():
        return
    entries = [_read(path) for path in cells.glob("*.json")]
    running = {entry.name for entry in entries if entry is not None and _alive(entry.pid)}
    for path in folder.iterdir():
        if path.name not in running:
            shutil.rmtree(path, ignore_errors=True)


@contextlib.contextmanager
def _locked(directory: Path) -> Iterator[None]:
    """An exclusive lock on the registry; the kernel releases it if this process dies."""
    descriptor = os.open(directory / ".lock", os.O_RDWR | os.O_CREAT, 0o600)
    try:
        fcntl.flock(descriptor, fcntl.LOCK_EX)
        yield
    finally:
        os.close(descriptor)


def _write_private(path: Path, data: bytes) -> None:
    descriptor = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(descriptor, "wb") as file:
        file.write(data)


def unregister(name: str, pid: int) -> None:
    """Remove ``name``'s entry if it is still the one ``pid`` wrote, and the credentials
    ``motocell up`` wrote for it (``credentials_dir``)."""
    directory = _cells_dir()
    path = directory / f"{name}.json"
    with _locked(directory):
        held = _read(path)
        if held is not None and held.pid == pid:
            path.unlink()
            shutil.rmtree(credentials_dir(name), ignore_errors=True)


def running() -> list[CellEntry]:
    """Every registered cell whose launcher is alive, by name."""
    entries = [_read(path) for path in sorted(_cells_dir().glob("*.json"))]
    return [entry for entry in entries if entry is not None and _alive(entry.pid)]


def find(name: str) -> CellEntry:
    """The running cell called ``name``; NoSuchCellError lists the cells there are."""
    for entry in running():
        if entry.name == name:
            return entry
    names = ", ".join(entry.name for entry in running()) or "none"
    raise NoSuchCellError(f"no cell named {name} is running here (running: {names})")
