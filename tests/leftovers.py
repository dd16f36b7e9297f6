"""What tests create outside their process, named so that a later run can find it.

Whatever a test makes beyond its own process carries its owner's pid in its name:

- ``mh<pid>...``: network namespaces and links of ``scripts/multihost`` (docs/multihost.md),
  its pid in six hex digits; its run directory ``/tmp/motocell-multihost-mh<pid>-XXXX``;
- ``mt<pid>...``: the suite's own namespaces and links, the pytest process's pid in six hex
  digits (``suite_tag``): six digits hold any pid (at most 2^22) and keep a link name within
  the kernel's 15 characters;
- ``motocell-cell-<pid>-XXXX`` in the temporary directory: a cell's run directory, its
  registry and credentials (``testing.running_cell``), owned by the process that started the cell;
- ``motocell-tests-<pid>-XXXX``: the registry a test session points every cell and tool at,
  so no test touches the user's own.

Each owner removes what it made, also when a test fails or pytest-timeout stops it. What an
owner killed outright (SIGKILL, a lost machine) left behind, the next run removes at its start
(``clean``) once the owner is gone, and says so: a namespace after the processes inside it,
a run directory after the cell registered in it.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import signal
import subprocess
import tempfile
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

import msgspec

from motocell.shared.registry import CellEntry
from motocell.testing.processes import alive, cmdline, wait_until

NETWORK_NAME = re.compile(r"m[ht](?P<owner>[0-9a-f]{6})")
"""The start of a namespace's or link's name: ``mh`` (scripts/multihost) or ``mt`` (tests)."""
RUN_DIRECTORY = re.compile(
    r"motocell-(?:multihost-mh(?P<hex>[0-9a-f]{6})|(?:cell|tests)-(?P<pid>[0-9]+))-"
)
"""The start of a run directory's name: scripts/multihost's, a cell's, a test session's."""
NAMESPACES = Path("/run/netns")
"""Where ``ip netns add`` keeps a namespace: one file each, named as the namespace."""
LINKS = Path("/sys/class/net")
"""This namespace's links, one entry each."""
STOP_S = 15.0
"""How long a left-over launcher may take to stop its cell (it stops it within 5 s)."""

Stale = Callable[[int], bool]
"""Whether what the owner with this pid made is left over."""


def suite_tag() -> str:
    """The start of every namespace and link name this process's tests create."""
    return f"mt{os.getpid():06x}"


def why_no_namespaces() -> str:
    """Why this machine cannot make network namespaces ("" when it can), found by making one
    under this suite's name: a run killed meanwhile leaves nothing the next cannot find."""
    if os.geteuid() != 0:
        return "needs root, to create network namespaces"
    if shutil.which("ip") is None:
        return "needs the ip command (iproute2)"
    probe = f"{suite_tag()}-probe"
    added = _ip("netns", "add", probe)
    if added.returncode != 0:
        return f"`ip netns add` fails here: {added.stderr.strip()}"
    _ip("netns", "delete", probe)
    return ""


def stale_at_start(owner: int) -> bool:
    """At the start of a run nothing bears this process's pid yet: what does belonged to an
    earlier process that had the same pid."""
    return owner == os.getpid() or not alive(owner)


def network_owner(name: str) -> int | None:
    found = NETWORK_NAME.match(name)
    return None if found is None else int(found["owner"], 16)


def directory_owner(name: str) -> int | None:
    found = RUN_DIRECTORY.match(name)
    if found is None:
        return None
    return int(found["hex"], 16) if found["hex"] else int(found["pid"])


def temporary_roots() -> set[Path]:
    """Where run directories are made: the temporary directory, and /tmp for the script."""
    return {Path(tempfile.gettempdir()), Path("/tmp")}


def clean() -> list[str]:
    """Remove what earlier runs left, at the start of a run: one line for each thing removed."""
    return clean_network(stale_at_start) + clean_directories(temporary_roots(), stale_at_start)


def clean_network(stale: Stale) -> list[str]:
    """Remove every namespace, then every link, whose owner is ``stale`` (needs root, as
    making them did)."""
    if os.geteuid() != 0 or shutil.which("ip") is None:
        return []
    removed = [_remove_namespace(name) for name in _names(NAMESPACES, stale)]
    return removed + [_remove_link(name) for name in _names(LINKS, stale)]


def clean_directories(roots: Iterable[Path], stale: Stale) -> list[str]:
    """Remove every run directory in ``roots`` whose owner is ``stale``, once the cells
    registered in it are stopped."""
    removed = []
    for directory in _directories(roots, stale):
        removed += _stop_cells(directory)
        shutil.rmtree(directory, ignore_errors=True)
        removed.append(f"directory {directory} ({_gone(directory_owner(directory.name))})")
    return removed


def _names(where: Path, stale: Stale) -> list[str]:
    found = sorted(entry.name for entry in where.iterdir()) if where.is_dir() else []
    return [name for name in found if (owner := network_owner(name)) is not None and stale(owner)]


def _directories(roots: Iterable[Path], stale: Stale) -> Iterator[Path]:
    for root in sorted(set(roots)):
        for path in sorted(root.glob("motocell-*")):
            owner = directory_owner(path.name)
            if owner is not None and _mine(path) and stale(owner):
                yield path


def _mine(path: Path) -> bool:
    """A directory of this user's (another user's is not ours to judge); False once another
    run removed it first."""
    try:
        return path.is_dir() and path.stat().st_uid == os.getuid()
    except OSError:
        return False


def _gone(owner: int | None) -> str:
    return f"its owner, pid {owner}, is gone"


def _ip(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(["ip", *args], capture_output=True, text=True, check=False)


def _remove_namespace(name: str) -> str:
    """Whatever still runs inside it belonged to the run that made it (as scripts/multihost's
    own clean-up does); so does anything outside whose arguments name the run (its delay
    line)."""
    inside = {int(pid) for pid in _ip("netns", "pids", name).stdout.split()}
    tag = name[: len("mh") + 6]
    named = {
        pid
        for pid in _processes()
        if pid != os.getpid() and any(tag in part for part in cmdline(pid))
    }
    for pid in inside | named:
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)
    _ip("netns", "delete", name)
    killed = f", {len(inside | named)} process(es) killed" if inside | named else ""
    return f"network namespace {name} ({_gone(network_owner(name))}{killed})"


def _remove_link(name: str) -> str:
    # Gone already when it was a veth pair's end whose other end was in a namespace removed
    # above: deleting it again changes nothing.
    _ip("link", "delete", name)
    return f"link {name} ({_gone(network_owner(name))})"


def _processes() -> list[int]:
    return [int(entry.name) for entry in Path("/proc").iterdir() if entry.name.isdigit()]


def _stop_cells(directory: Path) -> list[str]:
    """Stop the launchers registered in ``directory`` that still run: their harness is gone,
    so nothing else ever will. SIGTERM, as the harness would: the launcher stops its cell."""
    stopped = []
    for entry_file in sorted(directory.glob("cells/*.json")):
        with contextlib.suppress(OSError, msgspec.DecodeError, msgspec.ValidationError):
            entry = msgspec.json.decode(entry_file.read_bytes(), type=CellEntry)
            if alive(entry.pid) and _is_launcher(cmdline(entry.pid)):
                stopped.append(_stop_launcher(entry))
    return stopped


def _is_launcher(argv: list[str]) -> bool:
    """The harness's launcher or ``motocell up``; a pid reused since is none of our business."""
    return "motocell.services.launcher" in argv or (
        "up" in argv and any(part.endswith(("motocell", "motocell.tools.cli")) for part in argv)
    )


def _stop_launcher(entry: CellEntry) -> str:
    os.kill(entry.pid, signal.SIGTERM)
    try:
        wait_until(lambda: not alive(entry.pid), STOP_S, f"launcher {entry.pid} to stop")
    except TimeoutError:
        os.kill(entry.pid, signal.SIGKILL)
        return f"cell {entry.name}: its launcher, pid {entry.pid}, killed after {STOP_S} s"
    return f"cell {entry.name}: its launcher, pid {entry.pid}, stopped"
