"""The services exactly as compose.yaml runs them: same commands, same cell file, the same
generated router configuration (TLS only, passwords, access control), credentials written as
the compose instructions say. Only what must differ on a shared test machine is rewritten: the
router endpoint (a free loopback port instead of the zenohd container), paths inside the
images, and the gateway's listen address and port base."""

from __future__ import annotations

import contextlib
import io
import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from importlib.metadata import version
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from motocell.shared.bus.access import Identity, cell_identities
from motocell.shared.bus.catalog import SERVICES, Role
from motocell.shared.config import load_cell
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.ports import free_port_block
from motocell.shared.protocol.codec import ByteOrder
from motocell.shared.protocol.constants import Command, Result
from motocell.testing.client import MotionClient, StateListener, smooth_move, stream_ex
from motocell.testing.processes import alive, wait_until
from motocell.testing.running_cell import router_on_free_port, wait_for_whole_cell
from motocell.tools.cli import build_parser
from motocell.tools.deploy import (
    COMPOSE_CELL,
    CREDENTIALS_MOUNT,
    LISTEN,
    ROUTER_CONFIG,
    compose_router_settings,
    router_config_text,
)

LOCAL_CREDENTIALS = Path("deploy/credentials")
"""Where compose.yaml's instructions write the credentials, in the compose project."""

pytestmark = pytest.mark.cell


def compose_file(repo: Path) -> dict[str, Any]:
    compose: dict[str, Any] = yaml.safe_load((repo / "compose.yaml").read_text())
    return compose


def compose_commands(
    repo: Path, router: str, port_base: int, credentials: Path
) -> dict[str, list[str]]:
    """Each service's command, with what its container mounts at the credentials mount found
    in ``credentials`` (the directory compose's ``./deploy/credentials`` stands for)."""
    commands = {}
    for name, service in compose_file(repo)["services"].items():
        if name == "zenohd":
            continue
        command = [str(part) for part in service["command"]]
        assert command[:2] == ["python", "-m"], f"{name}: runs a motocell module"
        mounted = credentials / mounted_credentials(service).relative_to(LOCAL_CREDENTIALS)
        rewritten = [sys.executable, "-m"]
        for original in command[2:]:
            part = original.replace("tls/zenohd:7447", router)
            part = part.replace("/etc/motocell/cells/", f"{repo}/shared/cells/")
            part = part.replace(CREDENTIALS_MOUNT, str(mounted))
            rewritten.append({"0.0.0.0": "127.0.0.1", "50240": str(port_base)}.get(part, part))
        assert rewritten[rewritten.index("--credentials") + 1] == str(mounted), name
        commands[name] = rewritten
    return commands


def mounted_credentials(service: dict[str, Any]) -> Path:
    """The folder of the compose project that ``service`` mounts at the credentials mount."""
    (source,) = [
        volume.split(":")[0]
        for volume in service["volumes"]
        if volume.split(":")[1] == CREDENTIALS_MOUNT
    ]
    return Path(source)


def service_identity(command: list[str]) -> Identity:
    """Who a compose service's command runs as."""
    role = Role(command[2].removeprefix("motocell.services."))
    return Identity(role, command[command.index("--group") + 1] if "--group" in command else "0")


def router_config(repo: Path, credentials: Path, listen: str, out: Path) -> Path:
    """deploy/zenoh/router.json5 with this machine's paths and endpoint: the router's files
    where compose mounts them from, in ``credentials``."""
    mounted = credentials / mounted_credentials(
        compose_file(repo)["services"]["zenohd"]
    ).relative_to(LOCAL_CREDENTIALS)
    text = (repo / ROUTER_CONFIG).read_text()
    text = text.replace(CREDENTIALS_MOUNT, str(mounted)).replace(LISTEN, listen)
    out.write_text(text)
    return out


@pytest.fixture
def compose_cell(repo: Path, tmp_path: Path) -> Iterator[int]:
    credentials = tmp_path / "credentials"
    # As compose.yaml's instructions say, for the router's test address.
    argv = ["credentials", str(credentials), "--config", str(repo / COMPOSE_CELL), "--tls"]
    args = build_parser().parse_args([*argv, "--host", "127.0.0.1"])
    with contextlib.redirect_stdout(io.StringIO()):
        assert args.run(args) == 0
    config = tmp_path / "router.json5"

    def configured(endpoint: str) -> list[str]:
        return ["--config", str(router_config(repo, credentials, endpoint, config))]

    env = {**os.environ, "MOTOCELL_LOG": "WARNING"}
    processes: list[subprocess.Popen[bytes]] = []
    # As `docker compose down`: services first, the router they depend on last.
    with router_on_free_port(scheme="tls", configure=configured) as listen:
        # Bound by the gateway and the broadcaster started apart, as compose starts them: a
        # port taken in between fails the test (the router's is picked again).
        port_base = free_port_block(3)
        try:
            for command in compose_commands(repo, listen, port_base, credentials).values():
                processes.append(subprocess.Popen(command, env=env))
            yield port_base
        finally:
            stop_services(processes)


def stop_services(processes: list[subprocess.Popen[bytes]]) -> None:
    for process in reversed(processes):
        process.send_signal(signal.SIGTERM)
    for process in reversed(processes):
        try:
            process.wait(timeout=5)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
            raise AssertionError(f"{process.args!r} ignored SIGTERM") from None
    wait_until(lambda: not any(alive(p.pid) for p in processes), 5.0, "services to exit")


def test_compose_services_execute_a_trajectory(repo: Path, compose_cell: int) -> None:
    cell = load_cell(repo / COMPOSE_CELL)
    maps = [AxisMap(group) for group in cell.groups]
    byte_order = ByteOrder(cell.byte_order)

    wait_for_whole_cell("127.0.0.1", compose_cell, byte_order)
    with (
        StateListener("127.0.0.1", compose_cell + 1, byte_order).start() as state,
        MotionClient("127.0.0.1", compose_cell, byte_order) as motion,
    ):
        reply = motion.command(Command.START_TRAJ_MODE)
        assert (reply.result, reply.subcode) == (Result.SUCCESS, 0)
        still = state.wait_still()
        start = {g: tuple(still.groups[g].positions[: m.axes]) for g, m in enumerate(maps)}
        goals = {g: tuple(p + 0.2 for p in start[g]) for g in start}
        result = stream_ex(motion, {g: smooth_move(start[g], goals[g], 0.5, 6) for g in start})
        assert result.points == 6, result.last_reply
        targets = {g: m.ros_to_pulses(np.array(goals[g])) for g, m in enumerate(maps)}
        state.wait_for(
            lambda f: (
                f.status is not None
                and f.status.in_motion == 0
                and all(
                    np.array_equal(
                        m.ros_to_pulses(np.array(f.groups[g].positions[: m.axes])), targets[g]
                    )
                    for g, m in enumerate(maps)
                )
            ),
            10.0,
        )
        reply = motion.command(Command.STOP_TRAJ_MODE)
        assert (reply.result, reply.subcode) == (Result.SUCCESS, 0)


def test_compose_file_runs_every_service_and_an_interpolator_per_group(repo: Path) -> None:
    commands = compose_commands(repo, "tls/127.0.0.1:1", 1, Path("/creds"))
    modules = sorted(command[2] for command in commands.values())
    assert modules == [
        "motocell.services.broadcaster",
        "motocell.services.controller",
        "motocell.services.executor",
        "motocell.services.gateway",
        "motocell.services.interpolator",
        "motocell.services.interpolator",
        "motocell.services.interpolator",
    ]
    groups = sorted(c[c.index("--group") + 1] for c in commands.values() if "--group" in c)
    assert groups == ["0", "1", "2"]
    assert (repo / "deploy" / "Dockerfile").exists()


def test_compose_runs_one_container_per_service_identity_of_its_cell(repo: Path) -> None:
    """Derived from the identities the router's ACL is made for, not from a list of our own:
    a service the cell gains, or a group, fails here until compose runs it."""
    cell = load_cell(repo / COMPOSE_CELL)
    router_port = LISTEN.rpartition(":")[2]
    running = []
    for name, service in compose_file(repo)["services"].items():
        if name == "zenohd":
            continue
        command = [str(part) for part in service["command"]]
        running.append(service_identity(command))
        assert command[command.index("--config") + 1].endswith(Path(COMPOSE_CELL).name), name
        assert command[command.index("--zenoh-connect") + 1] == f"tls/zenohd:{router_port}", name
    services = [
        i
        for i in cell_identities(len(cell.groups), face=cell.ros2 is not None)
        if i.role in SERVICES
    ]
    assert sorted(i.name for i in running) == sorted(i.name for i in services)


def test_the_router_config_is_the_one_the_key_map_generates(repo: Path) -> None:
    assert (repo / ROUTER_CONFIG).read_text() == router_config_text(repo), (
        "deploy/zenoh/router.json5 is out of date: "
        "regenerate it with `python -m motocell.tools.deploy`"
    )


def test_the_compose_router_is_tls_only_with_access_control(repo: Path) -> None:
    settings = compose_router_settings(repo)
    assert settings["listen"]["endpoints"] == [LISTEN]
    assert settings["transport"]["link"]["protocols"] == ["tls"]
    assert settings["transport"]["link"]["tls"]["enable_mtls"] is True
    assert settings["access_control"]["default_permission"] == "deny"
    assert settings["scouting"]["gossip"]["enabled"] is False
    assert settings["adminspace"]["enabled"] is False


def test_each_container_mounts_only_its_own_credentials_bundle(repo: Path) -> None:
    """The router its bundle and the generated config, each service its identity's bundle
    (read-only), nothing else; and the router image the Python wheel's Zenoh version, so the
    two speak the same protocol."""
    services = compose_file(repo)["services"]
    cell = load_cell(repo / COMPOSE_CELL)
    router = services.pop("zenohd")
    assert router["image"] == f"eclipse/zenoh:{version('eclipse-zenoh')}"
    config = router["command"][router["command"].index("-c") + 1]
    bundles = f"./{LOCAL_CREDENTIALS}/bundles"
    assert router["volumes"] == [
        f"./{ROUTER_CONFIG}:{config}:ro",
        f"{bundles}/router:{CREDENTIALS_MOUNT}:ro",
    ]
    for name, service in services.items():
        user = service_identity([str(part) for part in service["command"]]).username(cell.name)
        assert service["volumes"] == [f"{bundles}/{user}:{CREDENTIALS_MOUNT}:ro"], name
