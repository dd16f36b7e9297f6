"""The layer rule (ARCHITECTURE.md, The layer rule), enforced on every import in the tree.

tools -> testing and services -> shared. A service imports no other service; shared
imports nothing of ours above it; no core (``shared/protocol``, ``shared/motion``, each
service's ``core``) loads an I/O module, itself or through a module of ours. Relative imports
count as the absolute ones they stand for.
"""

from __future__ import annotations

import ast
import functools
from collections.abc import Iterator
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
PACKAGE = "motocell"
"""The one import root of the installed code; the top-level folders are its subpackages."""
OURS = frozenset({"shared", "services", "tools", "testing"})

MAY_IMPORT = {
    "shared": {"shared"},
    "services": {"shared"},
    "testing": {"testing", "shared"},
    "tools": {"tools", "testing", "services", "shared"},
}
"""Which of our top-level packages each may import (services: plus its own service)."""

IO_MODULES = frozenset(
    {
        *("socket", "ssl", "select", "selectors", "asyncio", "zenoh"),
        *("threading", "_thread", "subprocess", "multiprocessing", "concurrent", "signal"),
        *("time", "datetime"),
    }
)
"""What a core may not load, directly or through a module of ours: the network, threads,
processes, signals, and the clocks. A core decides from what it is given; its shell reads the
clock and passes the instant in (``now_ns``), so a unit test chooses the time and replays a
decision. ``time`` is refused whole, not only its clocks: what else a core could want from
it (``sleep``) is worse, and ``datetime`` reads the same clock."""
PURE = ("shared/protocol", "shared/motion")
"""Pure cores: no I/O at all."""


def modules(package: str) -> Iterator[Path]:
    yield from sorted((REPO / package).rglob("*.py"))


def module_name(path: Path, root: Path = REPO) -> str:
    """The dotted name ``path`` is imported by: ours under ``motocell``, tests as they are."""
    parts = path.relative_to(root).with_suffix("").parts
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join((PACKAGE, *parts) if parts[0] in OURS else parts)


@functools.cache
def imports(path: Path, root: Path = REPO) -> tuple[tuple[int, str], ...]:
    """Every module name ``path`` imports, with its line, wherever the import is. A relative
    import is resolved against ``path``'s package; ``from X import a`` names ``X`` and
    ``X.a`` (``a`` may be a module of ``X``)."""
    package = module_name(path.parent / "__init__.py", root).split(".")
    found: list[tuple[int, str]] = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = ".".join(package[: len(package) - node.level + 1]) if node.level else ""
            source = ".".join(part for part in (base, node.module or "") if part)
            found.append((node.lineno, source))
            found += [(node.lineno, f"{source}.{alias.name}") for alias in node.names]
    return tuple(found)


def violations() -> Iterator[str]:
    for package, allowed in MAY_IMPORT.items():
        for path in modules(package):
            relative = path.relative_to(REPO)
            own_service = relative.parts[1] if package == "services" else None
            for line, name in imports(path):
                root, top, *rest = (*name.split("."), "")
                if root != PACKAGE or top not in OURS:
                    continue
                if top in allowed:
                    continue
                if top == "services" and own_service and rest[:1] == [own_service]:
                    continue
                yield f"{relative}:{line} imports {name}"


OUR_MODULES = {module_name(path): path for package in OURS for path in modules(package)}


def executed(name: str) -> Iterator[Path]:
    """The files of ours that importing ``name`` runs: its packages' ``__init__`` and itself."""
    parts = name.split(".")
    for end in range(2, len(parts) + 1):
        path = OUR_MODULES.get(".".join(parts[:end]))
        if path is not None:
            yield path


def io_loaded_by(start: Path) -> Iterator[str]:
    """Every import of an I/O module that loading ``start`` runs: its own, and those of each
    module of ours it loads, however deep."""
    seen, queue = {start}, [start]
    while queue:
        path = queue.pop()
        for line, name in imports(path):
            if name.split(".")[0] in IO_MODULES:
                yield f"{path.relative_to(REPO)}:{line} imports {name}"
            for loaded in executed(name):
                if loaded not in seen:
                    seen.add(loaded)
                    queue.append(loaded)


def cores() -> list[Path]:
    """The pure cores' modules and everything under a service's ``core/`` folder: a module is
    pure by where it sits, whoever imports it."""
    pure = [path for prefix in PURE for path in modules(prefix)]
    services = [
        path for path in modules("services") if path.relative_to(REPO).parts[2:3] == ("core",)
    ]
    return pure + services


def core_violations() -> Iterator[str]:
    for path in cores():
        for found in io_loaded_by(path):
            yield f"{path.relative_to(REPO)}: {found}"


def test_every_import_follows_the_layer_rule() -> None:
    assert list(violations()) == []


def test_nothing_imports_a_folder_by_its_bare_name() -> None:
    """``shared.x`` and ``motocell.shared.x`` would be two modules with two copies of each fact."""
    bare = [
        f"{path.relative_to(REPO)}:{line} imports {name}"
        for path in [*modules("tests"), *(p for package in OURS for p in modules(package))]
        for line, name in imports(path)
        if name.split(".")[0] in OURS
    ]
    assert bare == []


def test_cores_import_no_io() -> None:
    assert list(core_violations()) == []


def test_every_service_core_is_checked() -> None:
    """Guards the test itself: a core moved or renamed must not drop out of the check."""
    checked = {
        path.relative_to(REPO).parts[1]
        for path in cores()
        if path.is_relative_to(REPO / "services")
    }
    services = {p.name for p in (REPO / "services").iterdir() if (p / "__init__.py").exists()}
    assert checked == services


def test_io_is_found_through_modules_of_ours() -> None:
    """Guards the test itself: the gateway's wiring loads the socket module through its TCP
    adapter, one module away."""
    found = list(io_loaded_by(REPO / "services" / "gateway" / "__main__.py"))
    assert any(line.startswith("services/gateway/tcp.py:") and "socket" in line for line in found)


def test_relative_imports_resolve_against_their_package(tmp_path: Path) -> None:
    core = tmp_path / "services" / "gateway" / "core.py"
    core.parent.mkdir(parents=True)
    core.write_text("from . import tcp\nfrom ..executor.rings import Ring\nfrom .. import shared\n")
    assert imports(core, tmp_path) == (
        (1, "motocell.services.gateway"),
        (1, "motocell.services.gateway.tcp"),
        (2, "motocell.services.executor.rings"),
        (2, "motocell.services.executor.rings.Ring"),
        (3, "motocell.services"),
        (3, "motocell.services.shared"),
    )


WITHOUT_LOOP = {
    "gateway": "its threads are the TCP servers' (tcp.py) and the cell adapter's (zenoh_cell.py)",
}
"""Services whose work is not one thread of their own, and where their threads are."""
WITHOUT_BUS = {
    "launcher": "it joins no bus as a service: it runs the router and the services' processes",
}
"""Services with no bus adapter, and why."""


def service_folders() -> list[Path]:
    return sorted(p for p in (REPO / "services").iterdir() if (p / "__init__.py").exists())


def shape_problems(service: Path) -> Iterator[str]:
    """What ``service`` lacks of the one shape (STYLE.md 10): ``__main__`` wires, ``core/``
    decides (pure, its state table in ``core/states.py``), ``loop.py`` runs the thread,
    ``bus.py`` is the bus adapter."""
    name = service.name
    wanted = ["__main__.py", "core/__init__.py", "core/states.py"]
    wanted += [] if name in WITHOUT_LOOP else ["loop.py"]
    wanted += [] if name in WITHOUT_BUS else ["bus.py"]
    yield from (
        f"services/{name} has no {part}" for part in wanted if not (service / part).exists()
    )
    if (service / "core.py").exists():
        yield f"services/{name}/core.py: a core is the core/ package"


def test_every_service_has_the_one_shape() -> None:
    assert [problem for service in service_folders() for problem in shape_problems(service)] == []


def test_the_shape_exceptions_name_real_services() -> None:
    """Guards the test itself: an exception for a service renamed or gone must not linger."""
    names = {service.name for service in service_folders()}
    assert set(WITHOUT_LOOP) | set(WITHOUT_BUS) <= names


@pytest.mark.parametrize("package", sorted(MAY_IMPORT))
def test_the_rule_sees_the_package(package: str) -> None:
    """Guards the test itself: a renamed folder must not make it pass vacuously."""
    assert any(True for _ in modules(package))
