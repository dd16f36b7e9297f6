"""``motocell ps`` and ``watch`` warn, one line, when a certificate of the credentials they
use ends within 30 days; reading them loads no TLS library."""

from __future__ import annotations

import contextlib
import io
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from motocell.tools.cli import build_parser
from tests.certificates import expire_in
from tests.routers import mutual_tls_router

CELL = "lab"
TLS_LIBRARIES = {"cryptography", "ssl"}


def motocell(*argv: str) -> int:
    args = build_parser().parse_args(argv)
    status: int = args.run(args)
    return status


@pytest.fixture
def secured(tmp_path: Path) -> Iterator[tuple[str, Path]]:
    """A mutual-TLS router of cell lab, and the observer's bundle, whose certificate ends in
    ten days."""
    directory = tmp_path / "c"
    with contextlib.redirect_stdout(io.StringIO()):
        assert motocell("credentials", str(directory), "--cell", CELL, "--tls") == 0
    expire_in(directory, f"{CELL}.observer.pem", 10)
    with contextlib.redirect_stdout(io.StringIO()):
        assert motocell("credentials", str(directory)) == 0  # its bundle too

    endpoint, router = mutual_tls_router(directory, CELL)
    try:
        yield endpoint, directory / "bundles" / f"{CELL}.observer"
    finally:
        router.close()


def test_ps_warns_once_and_still_lists(
    secured: tuple[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    endpoint, bundle = secured
    argv = ["--zenoh-connect", endpoint, "--cell", CELL, "--credentials", str(bundle)]
    assert motocell("ps", *argv) == 0
    out, err = capsys.readouterr()
    (line,) = err.splitlines()
    assert line.startswith(f"motocell ps: certificates of {bundle} end within 30 days: ")
    assert f"{CELL}.observer.pem expires " in line and "ca.pem" not in line
    assert out.startswith(f"no motocell service is live on cell {CELL}")


def test_nothing_is_said_of_certificates_far_from_their_end(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    directory = tmp_path / "c"
    assert motocell("credentials", str(directory), "--cell", CELL, "--tls") == 0

    endpoint, router = mutual_tls_router(directory, CELL)
    capsys.readouterr()
    try:
        argv = ["--zenoh-connect", endpoint, "--cell", CELL, "--credentials", str(directory)]
        assert motocell("ps", *argv) == 0
    finally:
        router.close()
    assert capsys.readouterr().err == ""


@pytest.mark.cell
@pytest.mark.parametrize("command", [["ps"], ["watch", "--count", "1"]])
def test_the_warning_loads_no_tls_library(
    command: list[str], secured: tuple[str, Path], tmp_path: Path
) -> None:
    """As ``motocell`` runs it, in a fresh interpreter, to its end."""
    endpoint, bundle = secured
    argv = [*command, "--zenoh-connect", endpoint, "--cell", CELL, "--credentials", str(bundle)]
    code = (
        "import sys\n"
        "from motocell.tools import cli\n"
        "try:\n"
        f"    cli.main({argv!r})\n"
        "except SystemExit as exc:\n"
        "    assert not exc.code, exc.code\n"
        f"print(sorted(set(sys.modules) & {TLS_LIBRARIES!r}))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code],
        cwd=tmp_path,
        env={**os.environ, "MOTOCELL_LOG": "WARNING"},
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[-1] == "[]"
    warned = [line for line in done.stderr.splitlines() if "end within 30 days" in line]
    assert len(warned) == 1 and warned[0].startswith(f"motocell {command[0]}: certificates of")
