"""The launcher's decisions: a cell's children and their command lines, the router's endpoints,
and the restart policy. No process is started; time is passed in."""

from __future__ import annotations

import pytest

from services.launcher.core import (
    RESTART_DELAY_S,
    WELL_KNOWN_ENDPOINT,
    ChildSpec,
    Restart,
    RestartPolicy,
    UnknownServiceError,
    UpOptions,
    child_specs,
    router_endpoints,
)
from shared.config import EXIT_CONFIG, Cell, load_cell, parse_cell

ENDPOINT = "tcp/127.0.0.1:7500"
PYTHON = ("py", "-m")
ONE_ARM = load_cell(None)
DUAL = parse_cell(
    {
        "groups": [
            {"name": "R1", "model": "arm6"},
            {"name": "R2", "model": "arm7"},
            {"name": "S1", "model": "positioner2"},
        ]
    }
)


def specs(cell: Cell = ONE_ARM, options: UpOptions | None = None) -> dict[str, ChildSpec]:
    chosen = child_specs(cell, options or UpOptions(), ENDPOINT, PYTHON)
    return {spec.name: spec for spec in chosen}


def argv(cell: Cell = ONE_ARM, name: str = "controller") -> list[str]:
    return list(specs(cell)[name].argv)


# -- which children -----------------------------------------------------------------------


def test_a_one_arm_cell_runs_five_services_in_start_order() -> None:
    assert list(specs()) == ["controller", "executor", "broadcaster", "interpolator/0", "gateway"]


def test_one_interpolator_per_group() -> None:
    names = list(specs(DUAL))
    assert [n for n in names if n.startswith("interpolator/")] == [
        "interpolator/0",
        "interpolator/1",
        "interpolator/2",
    ]
    assert len(names) == 4 + len(DUAL.groups)


def test_each_interpolator_is_told_its_group() -> None:
    command = argv(DUAL, "interpolator/2")
    assert command[command.index("--group") + 1] == "2"


def test_skipped_services_are_left_out() -> None:
    names = list(specs(DUAL, UpOptions(skip=("interpolator/1", "gateway"))))
    assert "interpolator/1" not in names
    assert "gateway" not in names
    assert "interpolator/0" in names


def test_skipping_a_service_the_cell_lacks_names_what_it_has() -> None:
    with pytest.raises(UnknownServiceError, match=r"interpolator/3.*services: controller"):
        specs(DUAL, UpOptions(skip=("interpolator/3",)))


def test_an_unknown_skip_is_refused_even_beside_a_known_one() -> None:
    with pytest.raises(UnknownServiceError, match="bogus"):
        specs(options=UpOptions(skip=("gateway", "bogus")))


# -- command lines ------------------------------------------------------------------------


def test_each_child_runs_its_service_module_connected_to_the_endpoint() -> None:
    for name, spec in specs().items():
        module = name.split("/")[0]
        assert spec.argv[:3] == (*PYTHON, f"services.{module}")
        assert spec.argv[spec.argv.index("--zenoh-connect") + 1] == ENDPOINT


def test_without_options_children_get_only_the_endpoint() -> None:
    assert argv() == [*PYTHON, "services.controller", "--zenoh-connect", ENDPOINT]


def test_config_name_and_credentials_go_to_every_child() -> None:
    options = UpOptions(config="cell.toml", name="left", credentials="/run/creds")
    for spec in specs(options=options).values():
        command = list(spec.argv)
        assert command[command.index("--config") + 1] == "cell.toml"
        assert command[command.index("--name") + 1] == "left"
        assert command[command.index("--credentials") + 1] == "/run/creds"


def test_port_options_go_to_the_services_that_serve_tcp_only() -> None:
    chosen = specs(options=UpOptions(host="0.0.0.0", port_base=50300, byte_order="big"))
    for name in ("gateway", "broadcaster"):
        argv = list(chosen[name].argv)
        assert argv[-6:] == ["--host", "0.0.0.0", "--port-base", "50300", "--byte-order", "big"]
    for name, spec in chosen.items():
        if name not in ("gateway", "broadcaster"):
            assert "--host" not in spec.argv
            assert "--port-base" not in spec.argv


# -- router endpoints ---------------------------------------------------------------------


def no_spare_port() -> int:
    raise AssertionError("no spare port should be needed")


def test_a_router_listens_where_it_is_told() -> None:
    listen, connect = router_endpoints(["tcp/127.0.0.1:9000"], False, no_spare_port, link=True)
    assert (listen, connect) == (["tcp/127.0.0.1:9000"], [])


def test_the_first_cell_takes_the_well_known_port() -> None:
    assert router_endpoints([], True, no_spare_port, link=True) == ([WELL_KNOWN_ENDPOINT], [])


def test_a_later_cell_listens_on_a_spare_port_and_links_to_the_first() -> None:
    listen, connect = router_endpoints([], False, lambda: 9123, link=True)
    assert (listen, connect) == (["tcp/127.0.0.1:9123"], [WELL_KNOWN_ENDPOINT])


def test_a_secured_cell_links_to_no_other_router() -> None:
    listen, connect = router_endpoints([], False, lambda: 9123, link=False)
    assert (listen, connect) == (["tcp/127.0.0.1:9123"], [])


# -- restarts -----------------------------------------------------------------------------


def test_a_dead_child_is_noticed_once_then_waits_then_restarts() -> None:
    policy = RestartPolicy(delay_s=1.0)
    assert policy.dead("executor", 10.0) is Restart.NOTICED
    assert policy.dead("executor", 10.2) is Restart.WAIT
    assert policy.dead("executor", 10.999) is Restart.WAIT
    assert policy.dead("executor", 11.0) is Restart.NOW


def test_a_child_that_cannot_start_as_configured_stops_the_cell() -> None:
    assert RestartPolicy().dead("gateway", 0.0, EXIT_CONFIG) is Restart.GIVE_UP
    assert RestartPolicy().dead("gateway", 0.0, 1) is Restart.NOTICED


def test_a_child_that_dies_again_after_its_restart_is_noticed_again() -> None:
    policy = RestartPolicy(delay_s=1.0)
    policy.dead("gateway", 0.0)
    assert policy.dead("gateway", 1.0) is Restart.NOW
    assert policy.dead("gateway", 5.0) is Restart.NOTICED
    assert policy.dead("gateway", 5.5) is Restart.WAIT
    assert policy.dead("gateway", 6.0) is Restart.NOW


def test_children_have_their_own_delays() -> None:
    policy = RestartPolicy(delay_s=1.0)
    policy.dead("executor", 0.0)
    assert policy.dead("interpolator/0", 0.5) is Restart.NOTICED
    assert policy.dead("executor", 1.0) is Restart.NOW
    assert policy.dead("interpolator/0", 1.0) is Restart.WAIT
    assert policy.dead("interpolator/0", 1.5) is Restart.NOW


def test_a_late_look_restarts_at_once() -> None:
    policy = RestartPolicy(delay_s=1.0)
    policy.dead("controller", 0.0)
    assert policy.dead("controller", 60.0) is Restart.NOW


def test_the_default_delay_is_a_second() -> None:
    assert RestartPolicy().delay_s == RESTART_DELAY_S == 1.0
