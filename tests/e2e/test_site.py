"""One router for a site's cells (docs/site.md): three secured cells on one TLS router
that `motocell site` configured, each cell's services joined with the site's credentials.

Each cell moves its robot exactly; every identity of one cell is refused on every key of
another (its puts change nothing there, its subscription, queries and liveliness get nothing);
the site observer sees all three cells with `motocell ps` and `motocell watch`. The cells are
shared by the module's tests: each test checks its own effect on a cell the others leave at
rest.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, replace
from pathlib import Path

import pytest
import zenoh

from motocell.shared.bus.access import (
    ROUTER_SUFFIX,
    SITE_OBSERVER,
    SITE_ROUTER,
    Identity,
    cell_identities,
)
from motocell.shared.bus.bundles import ROUTER_BUNDLE, bundle_path
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.certificates import issue_client_certificate, load_authority
from motocell.shared.bus.credentials import load, load_user
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import ControllerStatus
from motocell.shared.bus.session import open_session
from motocell.shared.config import load_cell
from motocell.shared.ports import free_port
from motocell.shared.protocol.codec import ByteOrder
from motocell.shared.protocol.constants import Command, Result
from motocell.shared.registry import ENV as RUNTIME_DIR_ENV
from motocell.testing.processes import wait_until
from motocell.testing.running_cell import (
    LAUNCHER,
    ROUTER,
    STOP_TIMEOUT_S,
    RunningCell,
    SampleLog,
    TickLog,
    router_on_free_port,
    running_cell,
    wait_for_whole_cell,
    zenoh_router,
)
from motocell.tools.demo import drive
from tests.e2e.conftest import START_DEADLINE_S, TEST_CELLS
from tests.e2e.test_bus_security import assert_untouched, attack
from tests.e2e.test_scaling import other_host

pytestmark = pytest.mark.cell

Motocell = Callable[..., subprocess.CompletedProcess[str]]
CELL_FILES = ("single-arm", "fs100", str(TEST_CELLS / "ideal-servo.toml"))
"""Three one-group cells (cell1, fs100, ideal): the lightest the machine can run at once."""
DEADLINE_S = 60.0
"""For what an idle machine does at once: a bound for a hang, not a speed."""
IN_NAMESPACE = ("ip", "netns", "exec")
ROUTER_PORT = 7447
PORT_BASE = 50240
"""Host B is a namespace of the test's own: nothing else listens there."""
FAILOVER = (sys.executable, "-m", "motocell.tools.multihost", "failover")
SAMPLES_SEEN = 2
"""Statuses the site observer must see after a foreign subscription was declared: the foreign
subscriber had as long to receive them."""


@dataclass
class Site:
    credentials: Path
    endpoint: str
    cells: list[RunningCell]


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory, motocell: Motocell) -> Iterator[Site]:
    """Credentials for the three cells under one CA, the router `motocell site` writes for
    them, and the three cells joined to it."""
    directory = tmp_path_factory.mktemp("site") / "credentials"
    for index, config in enumerate(CELL_FILES):
        tls = ["--tls", "--host", "127.0.0.1"] if index == 0 else []
        made = motocell("credentials", str(directory), "--config", config, *tls)
        assert made.returncode == 0, made.stderr
    config_file = directory.parent / "router.json5"
    options = [arg for config in CELL_FILES for arg in ("--config", config)]

    def site_router(endpoint: str) -> list[str]:
        written = motocell(
            "site", str(directory), *options, "--listen", endpoint, "--out", str(config_file)
        )
        assert written.returncode == 0, written.stderr
        return ["--config", str(config_file)]

    with ExitStack() as stack:
        endpoint = stack.enter_context(router_on_free_port(scheme="tls", configure=site_router))
        cells = [
            stack.enter_context(
                running_cell(
                    config,
                    router=endpoint,
                    credentials=directory,
                    timeout=START_DEADLINE_S,
                    attempts=2,
                )
            )
            for config in CELL_FILES
        ]
        yield Site(directory, endpoint, cells)


def test_each_cell_of_the_site_moves_its_robot_exactly(site: Site) -> None:
    for cell in site.cells:
        status = drive(
            cell.cell, cell.host, cell.port_base, byte_order=cell.byte_order, points=8, duration=1.0
        )
        assert status == 0, f"cell {cell.cell.name} did not arrive exactly"


def test_every_identity_of_one_cell_gets_nothing_of_another(site: Site) -> None:
    one, other = site.cells[0], site.cells[1]
    watcher = open_session(
        "client",
        [site.endpoint],
        wait=False,
        credentials=load_user(site.credentials, SITE_OBSERVER),
    )
    ticks = TickLog(watcher, other.keys)
    try:
        with other.motion() as motion:
            # Motion-ready, as a driver leaves it: an attack that dropped it would show.
            assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
        for identity in cell_identities(len(one.cell.groups)):
            foreign = open_session(
                "client",
                [site.endpoint],
                wait=False,
                credentials=load(site.credentials, one.cell.name, identity),
            )
            try:
                _refused_everything(foreign, other, watcher, f"{identity.name} of the other cell")
                mark = len(ticks)
                attack(foreign, other)
                assert_untouched(other, ticks, watcher, mark)
            finally:
                foreign.close()
    finally:
        ticks.subscriber.undeclare()
        watcher.close()


def test_a_client_certificate_with_the_routers_name_passes_for_no_router(
    site: Site, tmp_path: Path
) -> None:
    """A client certificate named like the router (``<cell>.router``, which `motocell
    credentials --identity` issued until it refused to), signed by the site's CA, with a valid
    password of another identity: the router dials no other, so no subject is a certificate
    alone, and the pair matches none. It gets nothing of its cell or another."""
    first = site.cells[0].cell.name
    rogue = tmp_path / "rogue"
    rogue.mkdir(mode=0o700)
    certificate, key = issue_client_certificate(
        rogue, f"{first}{ROUTER_SUFFIX}", load_authority(site.credentials)
    )
    observer = load(site.credentials, first, Identity(Role.OBSERVER))
    posing = replace(observer, certificate=certificate, key=key)
    watcher = open_session(
        "client",
        [site.endpoint],
        wait=False,
        credentials=load_user(site.credentials, SITE_OBSERVER),
    )
    try:
        for cell in site.cells[:2]:
            foreign = open_session("client", [site.endpoint], wait=False, credentials=posing)
            ticks = TickLog(watcher, cell.keys)
            try:
                with cell.motion() as motion:
                    assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
                who = f"{observer.user}'s password with the certificate of {first}.router"
                _refused_everything(foreign, cell, watcher, who)
                mark = len(ticks)
                attack(foreign, cell)
                assert_untouched(cell, ticks, watcher, mark)
            finally:
                ticks.subscriber.undeclare()
                foreign.close()
    finally:
        watcher.close()


def _refused_everything(
    foreign: zenoh.Session, other: RunningCell, watcher: zenoh.Session, who: str
) -> None:
    """``foreign`` subscribes to all of ``other``'s keys and tokens, declares a token among
    them and asks on a key of every query route there: nothing comes and no token appears,
    while the site observer receives the statuses, the answer and the tokens alongside."""
    keys = other.keys
    samples: list[str] = []
    subscriber = foreign.declare_subscriber(
        f"{keys.prefix}/**", lambda sample: samples.append(str(sample.key_expr))
    )
    tokens: list[str] = []
    token_subscriber = foreign.liveliness().declare_subscriber(
        f"@motocell/{other.cell.name}/**",
        lambda sample: tokens.append(str(sample.key_expr)),
        history=True,
    )
    planted_key = keys.alive("gateway", "9")
    planted = foreign.liveliness().declare_token(planted_key)
    seen = SampleLog(watcher, keys.controller_status, ControllerStatus)
    try:
        wait_until(lambda: len(seen) >= SAMPLES_SEEN, DEADLINE_S, "the site observer's statuses")
        assert not samples, f"{who} received {other.cell.name}'s samples"
        # Its own token reaches its own subscriber inside the session, never the router.
        assert not [key for key in tokens if key != planted_key], (
            f"{who} saw {other.cell.name}'s liveliness tokens"
        )
        for asked in _queries(keys):
            answered = [r for r in foreign.get(asked, timeout=2.0) if r.ok]
            assert not answered, f"{who} was answered on {asked}"
        info = keys.service_info("controller", "0")
        assert [r for r in watcher.get(info, timeout=DEADLINE_S) if r.ok], "no answer at all"
        alive = watcher.liveliness().get(keys.alive_all, timeout=DEADLINE_S)
        names = {str(reply.ok.key_expr) for reply in alive if reply.ok}
        assert keys.alive("controller", "0") in names, names
        assert planted_key not in names, f"{who} planted a token"
    finally:
        seen.subscriber.undeclare()
        subscriber.undeclare()
        token_subscriber.undeclare()
        planted.undeclare()


def _queries(keys: CellKeys) -> list[str]:
    """A key of every query route of the catalogue that its servers answer."""
    return [
        keys.controller_cmd("read_bit"),
        keys.controller_fault("hold"),
        keys.group_slot(0),
        keys.executor_cmd("stop"),
        keys.broadcaster_cmd("positions"),
        keys.service_info("controller", "0"),
    ]


def test_the_site_observer_acts_on_no_cell(site: Site) -> None:
    """Every put, command and fault the bus-security test tries, by the site observer, on
    each cell: nothing moves, no fault appears, motion-ready holds."""
    observer = load_user(site.credentials, SITE_OBSERVER)
    watcher = open_session("client", [site.endpoint], wait=False, credentials=observer)
    try:
        for cell in site.cells:
            ticks = TickLog(watcher, cell.keys)
            try:
                with cell.motion() as motion:
                    assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
                mark = len(ticks)
                attack(watcher, cell)
                assert_untouched(cell, ticks, watcher, mark)
            finally:
                ticks.subscriber.undeclare()
    finally:
        watcher.close()


def test_the_site_observer_sees_every_cell_with_ps_and_watch(
    site: Site, motocell: Motocell
) -> None:
    where = ["--zenoh-connect", site.endpoint, "--credentials", str(site.credentials)]
    listed = motocell("ps", *where)
    assert listed.returncode == 0, listed.stderr
    watched = motocell("watch", "--count", "1", *where, timeout=60.0)
    assert watched.returncode == 0, watched.stderr
    for cell in site.cells:
        name = cell.cell.name
        assert f"{name} " in listed.stdout or f" {name}" in listed.stdout, listed.stdout
        assert f"cell {name}" in watched.stdout, watched.stdout


def test_two_cells_on_a_two_router_mesh_across_hosts_each_move_exactly(
    tmp_path: Path, motocell: Motocell, network_namespaces: None
) -> None:
    """Host A (this namespace) runs router A and cell1; host B (a network namespace) runs
    router B, linked to A from only its bundles (the router's and site.router's, merged), and
    the ideal cell. Each cell moves exactly, and the site observer on router A sees both: cell
    ideal's traffic crosses the mesh."""
    config_a, config_b = CELL_FILES[0], CELL_FILES[2]
    with ExitStack() as stack:
        namespace, ours, theirs = stack.enter_context(other_host())
        directory = tmp_path / "credentials"
        for config, tls in (
            (config_a, ["--tls", "--host", ours, "--host", theirs]),
            (config_b, []),
        ):
            made = motocell("credentials", str(directory), "--config", config, *tls)
            assert made.returncode == 0, made.stderr
        router_a, router_b = f"tls/{ours}:{free_port()}", f"tls/{theirs}:{ROUTER_PORT}"
        both = ["--config", config_a, "--config", config_b]
        b_files = tmp_path / "router-b-files"
        for name, listen, extra in (
            ("a", router_a, []),
            ("b", router_b, ["--connect", router_a, "--files-at", str(b_files)]),
        ):
            out = tmp_path / f"router-{name}.json5"
            written = motocell(
                "site", str(directory), *both, "--listen", listen, *extra, "--out", str(out)
            )
            assert written.returncode == 0, written.stderr
        for bundle in (ROUTER_BUNDLE, SITE_ROUTER):
            shutil.copytree(bundle_path(directory, bundle), b_files, dirs_exist_ok=True)
        stack.enter_context(zenoh_router(config_file=tmp_path / "router-a.json5"))
        there = [*IN_NAMESPACE, namespace]
        stack.enter_context(
            _running([*there, *ROUTER, "--config", str(tmp_path / "router-b.json5")])
        )
        here = stack.enter_context(
            running_cell(config_a, router=router_a, credentials=directory, timeout=START_DEADLINE_S)
        )
        runtime = stack.enter_context(
            tempfile.TemporaryDirectory(prefix=f"motocell-cell-{os.getpid()}-")
        )
        launcher = [
            *LAUNCHER,
            "--config",
            config_b,
            "--host",
            theirs,
            "--port-base",
            str(PORT_BASE),
        ]
        launcher += ["--zenoh-connect", router_b, "--credentials", str(directory)]
        stack.enter_context(_running([*there, *launcher], {RUNTIME_DIR_ENV: runtime}))
        ideal = load_cell(config_b)
        wait_for_whole_cell(theirs, PORT_BASE, ByteOrder(ideal.byte_order), START_DEADLINE_S)
        for cell, host, port_base in (
            (here.cell, here.host, here.port_base),
            (ideal, theirs, PORT_BASE),
        ):
            status = drive(
                cell, host, port_base, byte_order=ByteOrder(cell.byte_order), points=8, duration=1.0
            )
            assert status == 0, f"cell {cell.name} did not arrive exactly"
        listed = motocell("ps", "--zenoh-connect", router_a, "--credentials", str(directory))
        assert listed.returncode == 0, listed.stderr
        for name in (here.cell.name, ideal.name):
            assert name in listed.stdout, listed.stdout


@contextmanager
def _running(command: list[str], env: dict[str, str] | None = None) -> Iterator[None]:
    """``command`` running, quiet; stopped (SIGTERM, then SIGKILL) and reaped at the end."""
    process = subprocess.Popen(
        command, env={**os.environ, "MOTOCELL_LOG": "WARNING", **(env or {})}
    )
    try:
        yield
    finally:
        process.terminate()
        try:
            process.wait(timeout=STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def test_a_mesh_router_dying_stops_motion_safely_and_no_service_restarts() -> None:
    """``multihost failover`` (docs/site.md, where its timings are measured): services given
    both routers of a mesh, the one they use killed mid-trajectory and never restarted. Checked
    here: no service restarts; the client is told, nothing moves after, and the cell moves
    exactly again after START_TRAJ_MODE; or, when the services were back before anything in
    flight was lost, the trajectory goes on whole. How soon is the measurement's."""
    run = subprocess.run(
        [*FAILOVER, "--runs", "1"], capture_output=True, text=True, timeout=120, check=False
    )
    report = {
        name.strip(): value.strip()
        for name, _, value in (line.partition(":") for line in run.stdout.splitlines())
        if value
    }
    said = run.stdout + run.stderr[-3000:]
    if report.get("NOT_READY told", "never") == "never":
        # The services were back before anything in flight was lost (the executor stops on
        # any gap, docs/motion-safety.md): the trajectory went on, every point taken.
        assert report.get("interrupted", "").startswith("no (every point taken"), said
    assert report.get("moved after told", "").startswith("0 ticks"), said
    assert report.get("services restarted") == "0", said
    assert report.get("recovery", "").startswith("START_TRAJ_MODE -> SUCCESS"), said
    assert report.get("new trajectory", "").startswith("20 of 20 points; 0 pulse(s)"), said
