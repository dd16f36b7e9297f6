"""Files a user gets wrong, given to the ``motocell`` command as a user would: a device, a FIFO,
a huge or binary file for a cell file, a cell named as the site's own identities, secrets
others may read. Each is one line naming the file and the fix, exit status 2, no traceback,
and nothing read without bound."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from motocell.shared.config import EXIT_CONFIG
from motocell.shared.files import CELL_FILE_LIMIT
from motocell.shared.ports import free_port, free_port_block

pytestmark = pytest.mark.cell

MOTOCELL = (sys.executable, "-m", "motocell.tools")
DEADLINE_S = 90.0
"""A hang or a read without end, not a slow start: an interpreter and its imports take
seconds on a loaded machine."""
NOWHERE = f"tcp/127.0.0.1:{free_port()}"


def motocell(tmp_path: Path, *args: str) -> tuple[int, str]:
    """``motocell ARGS`` to its end: its status, and what it printed (stdout and stderr)."""
    env = {**os.environ, "MOTOCELL_RUNTIME_DIR": str(tmp_path / "run")}
    result = subprocess.run(
        [*MOTOCELL, *args],
        capture_output=True,
        text=True,
        env=env,
        cwd=tmp_path,
        timeout=DEADLINE_S,
        check=False,
    )
    return result.returncode, result.stdout + result.stderr


def one_line(output: str) -> str:
    assert output.count("\n") == 1 and output.endswith("\n"), output
    assert "Traceback" not in output
    return output.strip()


def a_cell_file(tmp_path: Path, kind: str) -> Path:
    path = tmp_path / "cell.toml"
    if kind == "FIFO":
        os.mkfifo(path)  # nobody ever writes it: reading it would wait for ever
    elif kind == "binary":
        path.write_bytes(bytes(range(256)) * 4)
    elif kind == "huge":
        with path.open("wb") as sparse:  # 8 GiB that take no disk
            sparse.truncate(8 << 30)
    return path


@pytest.mark.parametrize(
    ("kind", "problem"),
    [
        ("device", "is not a regular file (a device)"),
        ("FIFO", "is not a regular file (a FIFO)"),
        ("binary", "is not a text file (no UTF-8 at byte 128): not the file meant?"),
        ("huge", f"is larger than {CELL_FILE_LIMIT >> 20} MiB: not the file meant?"),
    ],
)
@pytest.mark.parametrize("command", ["up", "credentials"])
def test_a_cell_file_that_is_no_cell_file_is_one_line(
    tmp_path: Path, command: str, kind: str, problem: str
) -> None:
    config = "/dev/zero" if kind == "device" else str(a_cell_file(tmp_path, kind))
    if command == "up":
        args = ["up", "--config", config, "--zenoh-listen", NOWHERE]
    else:
        args = ["credentials", str(tmp_path / "credentials"), "--config", config]
    status, output = motocell(tmp_path, *args)
    assert status == EXIT_CONFIG, output
    assert one_line(output) == f"motocell {command}: cell file {config} {problem}"
    assert not (tmp_path / "credentials").exists()


def test_a_cell_named_site_gets_no_credentials_that_motocell_site_would_refuse(
    tmp_path: Path,
) -> None:
    site = tmp_path / "site"
    assert motocell(tmp_path, "credentials", str(site), "--cell", "lab")[0] == 0
    before = sorted(path.name for path in site.iterdir())
    status, output = motocell(tmp_path, "credentials", str(site), "--cell", "site")
    assert status == EXIT_CONFIG, output
    refusal = one_line(output)
    assert refusal.startswith("motocell credentials: a cell named site gets no credentials")
    assert "--cell NAME" in output
    assert sorted(path.name for path in site.iterdir()) == before


@pytest.mark.parametrize("command", ["ps", "service", "up"])
def test_a_password_other_users_may_read_is_refused_with_the_fix(
    tmp_path: Path, command: str
) -> None:
    directory = tmp_path / "credentials"
    assert motocell(tmp_path, "credentials", str(directory))[0] == 0
    user = {"ps": "observer", "service": "controller", "up": "observer"}[command]
    password = directory / f"cell1.{user}.password"
    password.chmod(0o644)
    joining = ["--zenoh-connect", NOWHERE, "--credentials", str(directory)]
    args = {
        "ps": ["ps", "--cell", "cell1", *joining],
        "service": ["service", "controller", *joining],
        "up": ["up", "--port-base", str(free_port_block(3)), *joining],
    }[command]
    status, output = motocell(tmp_path, *args)
    assert status == EXIT_CONFIG, output
    # A service says first that it starts (INFO); the refusal is its one line on stderr.
    refusal = [line for line in output.splitlines() if " INFO " not in line]
    assert len(refusal) == 1 and "Traceback" not in output, output
    assert refusal[0].endswith(
        f"{password} is open to other users (permissions 0644) and a password or key must be "
        f"its owner's alone: chmod 600 {password}"
    ), output
    password.chmod(0o600)
