"""The layer rule (ARCHITECTURE.md, first section), enforced on every import in the tree.

tools and bench -> testkit and services -> shared. A service imports no other service; shared
imports nothing of ours above it; the pure cores import no I/O at all.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
PACKAGE = "motocell"
"""The one import root of the installed code; the top-level folders are its subpackages."""
OURS = frozenset({"shared", "services", "tools", "testkit", "bench"})

MAY_IMPORT = {
    "shared": {"shared"},
    "services": {"shared"},
    "testkit": {"testkit", "shared"},
    "tools": {"tools", "bench", "testkit", "services", "shared"},
    "bench": {"bench", "testkit", "services", "shared"},
}
"""Which of our top-level packages each may import (services: plus its own service)."""

IO_MODULES = frozenset(
    {"zenoh", "socket", "asyncio", "threading", "subprocess", "select", "signal", "time"}
)
PURE = ("shared/protocol", "shared/motion")
"""Pure cores: no network, threads, processes, signals or clocks."""


def modules(package: str) -> Iterator[Path]:
    yield from sorted((REPO / package).rglob("*.py"))


def imports(path: Path) -> Iterator[tuple[int, str]]:
    """Every absolute module name ``path`` imports, with its line, wherever the import is."""
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            yield node.lineno, node.module


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


def core_violations() -> Iterator[str]:
    pure = [path for prefix in PURE for path in modules(prefix)]
    cores = [
        path
        for path in modules("services")
        if "core" in path.relative_to(REPO).parts or path.stem == "core"
    ]
    for path in pure + cores:
        forbidden = IO_MODULES if path in pure else {"zenoh"}
        for line, name in imports(path):
            if name.split(".")[0] in forbidden:
                yield f"{path.relative_to(REPO)}:{line} imports {name}"


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


def test_every_service_has_a_core_and_a_main() -> None:
    for service in sorted(p for p in (REPO / "services").iterdir() if (p / "__init__.py").exists()):
        has_core = (service / "core.py").exists() or (service / "core").is_dir()
        assert (service / "__main__.py").exists(), service.name
        assert has_core, f"services/{service.name} has no core"


@pytest.mark.parametrize("package", sorted(MAY_IMPORT))
def test_the_rule_sees_the_package(package: str) -> None:
    """Guards the test itself: a renamed folder must not make it pass vacuously."""
    assert any(True for _ in modules(package))
