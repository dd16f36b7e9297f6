"""How the tools find the cell they are asked about (the registry of running cells, or an
explicit router) and join its bus: at once, or with one line that says what to do.

The registry is this test's own (``$MOTOCELL_RUNTIME_DIR``); its entries name this process as
their launcher, so they count as running. The bus tests run a secured router in this process,
as the launcher does, and stand in for the cell's services with their own identities.
"""

from __future__ import annotations

import argparse
import os
import re
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import pytest
import zenoh

from motocell.shared import registry
from motocell.shared.bus.access import SITE_OBSERVER, Identity, cell_identities
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.credentials import add_passwords, load, write_passwords
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.router import router_settings, zenoh_config
from motocell.shared.bus.schemas import CommandReply, ServiceInfo, encode
from motocell.shared.bus.session import answer, open_session
from motocell.shared.ports import free_port
from motocell.shared.registry import CellEntry
from motocell.testing.ports import listening
from motocell.testing.processes import wait_until
from motocell.tools import cells
from motocell.tools.cells import Target, TargetError
from motocell.tools.cli import build_parser

CELL = "c1"


@pytest.fixture(autouse=True)
def own_registry(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    runtime = tmp_path / "runtime"
    monkeypatch.setenv(registry.ENV, str(runtime))
    return runtime


def register(name: str, endpoint: str = "tcp/127.0.0.1:7447", credentials: str = "") -> None:
    registry.register(
        CellEntry(
            name=name,
            pid=os.getpid(),
            host="127.0.0.1",
            port_base=50240,
            zenoh_endpoint=endpoint,
            credentials=credentials,
        )
    )


def motocell(*argv: str) -> int:
    """``motocell <argv>`` in this process: its exit status (output in capsys)."""
    args = build_parser().parse_args(argv)
    status: int = args.run(args)
    return status


# -- finding cells ------------------------------------------------------------------------------


def test_a_named_cell_is_found_with_its_router_and_credentials() -> None:
    register("arm", "tcp/127.0.0.1:7500", "/run/arm")
    register("other", "tcp/127.0.0.1:7501")
    found = cells.targets(build_parser().parse_args(["ps", "--cell", "arm"]))
    assert found == [Target("tcp/127.0.0.1:7500", ("arm",), Path("/run/arm"), os.getpid())]


def test_without_a_name_every_running_cell_is_a_target_of_its_own() -> None:
    register("b", "tcp/127.0.0.1:7501")
    register("a", "tcp/127.0.0.1:7500", "/run/a")
    found = cells.targets(build_parser().parse_args(["watch"]))
    assert found == [
        Target("tcp/127.0.0.1:7500", ("a",), Path("/run/a"), os.getpid()),
        Target("tcp/127.0.0.1:7501", ("b",), None, os.getpid()),
    ]


def test_a_cell_whose_launcher_is_gone_is_not_a_target(dead_pid: int) -> None:
    registry.register(
        CellEntry(name="old", pid=dead_pid, host="h", port_base=1, zenoh_endpoint="tcp/h:1")
    )
    assert cells.targets(build_parser().parse_args(["ps"])) == []


@pytest.mark.parametrize("command", ["ps", "watch", "fault estop on", "record out.mcap"])
def test_a_name_not_running_fails_at_once_listing_the_cells_that_are(
    command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    register("arm")
    register("gantry")
    words = command.split()
    assert motocell(*words, "--cell", "nosuch") == 2
    err = capsys.readouterr().err
    assert err == (
        f"motocell {words[0]}: no cell named nosuch is running here (running: arm, gantry)\n"
    )


def test_a_name_close_to_a_running_one_is_suggested() -> None:
    register("arm")
    register("gantry")
    args = argparse.Namespace(cell=["amr"], zenoh_connect=None, credentials=None)
    with pytest.raises(TargetError) as refused:
        cells.targets(args)
    assert str(refused.value) == (
        "no cell named amr is running here (running: arm, gantry); did you mean arm?"
    )


def test_fault_without_a_name_refuses_to_choose_between_two_cells(
    capsys: pytest.CaptureFixture[str],
) -> None:
    register("left")
    register("right")
    assert motocell("fault", "estop", "on") == 2
    assert capsys.readouterr().err == (
        "motocell fault: 2 cells are running here (left, right): choose one with --cell\n"
    )


def test_with_nothing_running_ps_says_so_and_the_others_fail(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """``watch`` waits for a cell instead (tests/tools/test_watch.py)."""
    assert motocell("ps") == 0
    assert capsys.readouterr().out == cells.NOTHING_RUNNING + "\n"
    for argv in (["fault", "hold", "on"], ["record", str(tmp_path / "x.mcap")]):
        assert motocell(*argv) == 2
        assert capsys.readouterr().err == f"motocell {argv[0]}: {cells.NOTHING_RUNNING}\n"
    assert not (tmp_path / "x.mcap").exists()


@pytest.mark.parametrize(
    ("argv", "problem"),
    [
        (["--credentials", "d"], "--credentials goes with --zenoh-connect"),
        (["--zenoh-connect", "tcp/h:1", "--credentials", "d"], "--credentials needs one --cell"),
        (
            ["--zenoh-connect", "tcp/h:1", "--credentials", "d", "--cell", "a", "--cell", "b"],
            "--credentials needs one --cell",
        ),
        (["--cell", "cell1/**"], "not a cell name: 'cell1/**'"),
        (["--cell", "*"], "not a cell name: '*'"),
    ],
)
def test_arguments_that_cannot_name_one_bus_are_refused(argv: list[str], problem: str) -> None:
    with pytest.raises(TargetError, match=re.escape(problem)):
        cells.targets(build_parser().parse_args(["ps", *argv]))


def test_a_sites_credentials_watch_every_cell_of_its_router(tmp_path: Path) -> None:
    """With the site observer's password there, --credentials needs no --cell (docs/site.md)."""
    add_passwords(tmp_path, [SITE_OBSERVER])
    argv = ["ps", "--zenoh-connect", "tcp/h:1", "--credentials", str(tmp_path)]
    assert cells.targets(build_parser().parse_args(argv)) == [Target("tcp/h:1", (), tmp_path)]


def test_an_explicit_router_is_joined_as_told() -> None:
    args = build_parser().parse_args(
        ["watch", "--zenoh-connect", "tls/robot:7447", "--cell", "a", "--credentials", "d"]
    )
    assert cells.targets(args) == [Target("tls/robot:7447", ("a",), Path("d"))]
    open_bus = build_parser().parse_args(["watch", "--zenoh-connect", "tcp/robot:7447"])
    assert cells.targets(open_bus) == [Target("tcp/robot:7447", ())]
    assert cells.targets(open_bus)[0].names == ("*",)


# -- joining a secured cell ---------------------------------------------------------------------


@dataclass
class Bus:
    endpoint: str
    credentials: Path


@pytest.fixture
def bus(tmp_path: Path) -> Iterator[Bus]:
    """A one-group cell's secured router, as its launcher runs it, and the cell registered."""
    credentials = tmp_path / "credentials"
    write_passwords(credentials, CELL, cell_identities(1))

    def open_router(endpoint: str) -> zenoh.Session:
        settings = router_settings(
            [endpoint], cell=CELL, identities=cell_identities(1), credentials=credentials
        )
        return zenoh.open(zenoh_config(settings))

    endpoint, router = listening(open_router)
    register(CELL, endpoint, str(credentials))
    yield Bus(endpoint, credentials)
    router.close()


def service(bus: Bus, role: Role) -> zenoh.Session:
    """A session as one of the cell's services."""
    credentials = load(bus.credentials, CELL, Identity(role))
    return open_session("client", [bus.endpoint], wait=False, credentials=credentials)


@pytest.fixture
def executor(bus: Bus) -> Iterator[None]:
    """The cell's executor, as ``ps`` sees it: a liveliness token and its info queryable."""
    session = service(bus, Role.EXECUTOR)
    keys = CellKeys(CELL)
    info = ServiceInfo(
        cell=CELL,
        service="executor",
        instance="0",
        host="here",
        pid=4242,
        started_unix_ns=0,
        version="9.9",
    )

    def describe(query: zenoh.Query) -> None:
        query.reply(keys.service_info("executor", "0"), encode(info))
        query.drop()

    queryable = session.declare_queryable(keys.service_info("executor", "0"), describe)
    token = session.liveliness().declare_token(keys.alive("executor", "0"))
    observer = service(bus, Role.OBSERVER)
    try:
        # Declared: the router has passed the token on, as it has for a cell that is up.
        wait_until(lambda: any(observer.liveliness().get(keys.alive_all)), 5.0, "the token")
        yield
    finally:
        observer.close()
        token.undeclare()
        queryable.undeclare()
        session.close()


@pytest.mark.cell  # ps waits METRICS_WAIT_S for metrics: tests/lanes.py
def test_ps_finds_a_secured_cell_and_joins_it_as_the_observer(
    bus: Bus, executor: None, capsys: pytest.CaptureFixture[str]
) -> None:
    assert motocell("ps") == 0
    out = capsys.readouterr().out.splitlines()
    assert out[1].split()[:5] == [CELL, "executor", "-", "here", "4242"]
    assert out[-1] == (
        f"cell {CELL}: Zenoh {bus.endpoint}, credentials {bus.credentials}; "
        "TCP motion ?, state ?, io ?"
    )


def test_fault_reaches_the_controller_as_the_operator(
    bus: Bus, capsys: pytest.CaptureFixture[str]
) -> None:
    controller = service(bus, Role.CONTROLLER)
    asked: list[str] = []

    def on_fault(query: zenoh.Query) -> None:
        asked.append(str(query.key_expr))
        answer(query, CommandReply(result=0, subcode=0))

    queryable = controller.declare_queryable(CellKeys(CELL).controller_fault("*"), on_fault)
    try:
        assert motocell("fault", "estop", "on") == 0, capsys.readouterr().err
    finally:
        queryable.undeclare()
        controller.close()
    assert capsys.readouterr().out == "estop on: SUCCESS\n"
    assert asked == [CellKeys(CELL).controller_fault("estop")]


def test_credentials_from_an_earlier_run_are_refused_at_once_in_one_line(
    bus: Bus, capsys: pytest.CaptureFixture[str]
) -> None:
    write_passwords(bus.credentials, CELL, cell_identities(1))  # the router keeps the old ones
    for argv in (["ps"], ["watch", "--count", "1"], ["fault", "estop", "on"]):
        assert motocell(*argv) == 1
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "Traceback" not in err, err
        assert err.startswith(f"motocell {argv[0]}: cell {CELL}: the Zenoh router at ")
        assert "refused" in err


def test_a_registered_cell_whose_router_is_not_there_is_reported_in_one_line(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    nowhere = f"tcp/127.0.0.1:{free_port()}"
    register("lost", nowhere)
    assert motocell("record", str(tmp_path / "x.mcap"), "--cell", "lost") == 1
    err = capsys.readouterr().err
    assert err.startswith(f"motocell record: cell lost: no Zenoh router answers at {nowhere}")
    assert err.count("\n") == 1
    assert not (tmp_path / "x.mcap").exists()


def test_an_open_router_without_credentials_is_told_to_bring_them(
    bus: Bus, capsys: pytest.CaptureFixture[str]
) -> None:
    assert motocell("ps", "--zenoh-connect", bus.endpoint) == 1
    err = capsys.readouterr().err
    assert "refused" in err and "--credentials DIR" in err, err
    assert (
        motocell(
            "ps",
            "--zenoh-connect",
            bus.endpoint,
            "--cell",
            CELL,
            "--credentials",
            str(bus.credentials),
        )
        == 0
    )


# -- an open router named outright --------------------------------------------------------------


@pytest.fixture
def open_router() -> Iterator[str]:
    endpoint, router = listening(lambda at: zenoh.open(zenoh_config(router_settings([at]))))
    yield endpoint
    router.close()


@contextmanager
def controllers(endpoint: str, *names: str) -> Iterator[list[str]]:
    """A controller of each named cell on an open router; yields the fault keys asked."""
    session = open_session("client", [endpoint], wait=False)
    asked: list[str] = []

    def on_fault(query: zenoh.Query) -> None:
        asked.append(str(query.key_expr))
        answer(query, CommandReply(result=0, subcode=0))

    queryables, tokens = [], []
    for name in names:
        keys = CellKeys(name)
        queryables.append(session.declare_queryable(keys.controller_fault("*"), on_fault))
        tokens.append(session.liveliness().declare_token(keys.alive("controller", "0")))
    try:
        wait_until(
            lambda: len(cells.cells_on(session)) == len(names), 5.0, "the controllers' tokens"
        )
        yield asked
    finally:
        for token in tokens:
            token.undeclare()
        for queryable in queryables:
            queryable.undeclare()
        session.close()


def test_fault_on_an_open_router_acts_on_the_one_cell_it_carries(
    open_router: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with controllers(open_router, "lab") as asked:
        assert motocell("fault", "hold", "on", "--zenoh-connect", open_router) == 0
    assert capsys.readouterr().out == "hold on: SUCCESS\n"
    assert asked == [CellKeys("lab").controller_fault("hold")]


def test_fault_on_an_open_router_with_two_cells_refuses_to_guess(
    open_router: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with controllers(open_router, "left", "right") as asked:
        assert motocell("fault", "hold", "on", "--zenoh-connect", open_router) == 2
        assert (
            motocell("fault", "hold", "on", "--zenoh-connect", open_router, "--cell", "right") == 0
        )
    assert capsys.readouterr().err == (
        f"motocell fault: {open_router} carries cells: left, right: choose one with --cell\n"
    )
    assert asked == [CellKeys("right").controller_fault("hold")]
