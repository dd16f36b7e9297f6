"""The service image runs, shown without a container engine: its files are
assembled from the repository exactly as deploy/Dockerfile's COPY lines say
(tests/dockerfile.py), installed as its RUN line does into a fresh venv, and every service
module and the image's own command are started from that venv, outside the source tree."""

from __future__ import annotations

import shlex
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.dockerfile import Image, assemble
from tests.installed import cell_starts_and_stops, clean_env, run

pytestmark = [pytest.mark.cell, pytest.mark.timeout(1800)]

ROOT = Path(__file__).resolve().parents[2]
HOST = "127.0.0.1"
INSTALL_TIMEOUT_S = 900.0
"""Generous: on a loaded machine pip builds and installs for minutes."""
HELP_TIMEOUT_S = 60.0
SKIPPED_RUN = {"useradd"}
"""Commands of the RUN line that make no file of the package: the account the image runs as."""


@pytest.fixture(scope="module")
def image(tmp_path_factory: pytest.TempPathFactory) -> Image:
    return assemble(ROOT / "deploy" / "Dockerfile", ROOT, tmp_path_factory.mktemp("image"))


@pytest.fixture(scope="module")
def venv(image: Image, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """A fresh venv with the image's RUN line done in it: its pip installs into the venv."""
    assert image.base.startswith(f"python:{sys.version_info.major}.{sys.version_info.minor}"), (
        f"the image's Python ({image.base}) is not the one this test runs"
    )
    home = tmp_path_factory.mktemp("venv")
    run([sys.executable, "-m", "venv", home], INSTALL_TIMEOUT_S, home, clean_env())
    for line in image.runs:
        for command in (shlex.split(part) for part in line.split("&&")):
            if command[0] in SKIPPED_RUN:
                continue
            assert command[:2] == ["pip", "install"], f"RUN {line}: not understood by this test"
            pip: list[str | Path] = [home / "bin" / "python", "-m", "pip", "install", "--quiet"]
            pip += command[2:]
            run(pip, INSTALL_TIMEOUT_S, image.path(image.workdir), clean_env())
    yield home


def service_modules() -> list[str]:
    return sorted(path.parent.name for path in (ROOT / "services").glob("*/__main__.py"))


@pytest.mark.parametrize("service", service_modules())
def test_every_service_module_starts_from_the_image(venv: Path, service: str) -> None:
    module = f"motocell.services.{service}"
    usage = run(
        [venv / "bin" / "python", "-m", module, "--help"], HELP_TIMEOUT_S, venv, clean_env()
    )
    assert "usage:" in usage, usage


def test_the_package_is_the_installed_one(venv: Path) -> None:
    where = run(
        [venv / "bin" / "python", "-c", "import motocell.shared; print(motocell.shared.__file__)"],
        HELP_TIMEOUT_S,
        venv,
        clean_env(),
    )
    assert Path(where.strip()).resolve().is_relative_to(venv.resolve()), where
    assert "usage:" in run([venv / "bin" / "motocell", "--help"], HELP_TIMEOUT_S, venv, clean_env())


def test_the_images_command_runs_a_cell(image: Image, venv: Path) -> None:
    """The CMD as the image runs it, with its paths inside the image and on loopback ports."""
    python, *arguments = image.cmd
    assert python == "python", image.cmd
    in_image = [str(image.path(part)) if part.startswith("/") else part for part in arguments]
    host = in_image.index("--host") + 1
    in_image[host] = HOST  # the image listens on every interface; a test on loopback only

    def command_on(port_base: int, router_port: int) -> list[str | Path]:
        return [
            venv / "bin" / "python",
            *in_image,
            *("--port-base", str(port_base), "--zenoh-listen", f"tcp/{HOST}:{router_port}"),
        ]

    cell_starts_and_stops(command_on, venv, venv, HOST)
