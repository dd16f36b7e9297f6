"""Which services a cell runs here and their command lines. No process is started."""

from __future__ import annotations

import itertools

import pytest

from motocell.services.launcher.core.children import (
    ChildSpec,
    UpOptions,
    child_specs,
    services_here,
)
from motocell.shared.config import Cell, load_cell, parse_cell
from motocell.shared.service_names import UnknownServiceError

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


def specs(
    cell: Cell = ONE_ARM, options: UpOptions | None = None, skip: tuple[str, ...] = ()
) -> dict[str, ChildSpec]:
    chosen = child_specs(services_here(cell, skip), options or UpOptions(), [ENDPOINT], PYTHON)
    return {spec.name: spec for spec in chosen}


def argv(cell: Cell = ONE_ARM, name: str = "controller/0") -> list[str]:
    return list(specs(cell)[name].argv)


def test_every_router_joined_is_given_to_every_service() -> None:
    """A site's mesh: a service fails over to another router of it (docs/site.md)."""
    routers = ["tls/a:7447", "tls/b:7447"]
    chosen = child_specs(services_here(ONE_ARM, ()), UpOptions(), routers, PYTHON)
    for spec in chosen:
        joined = [b for a, b in itertools.pairwise(spec.argv) if a == "--zenoh-connect"]
        assert joined == routers, spec.name


# -- which children -----------------------------------------------------------------------


def test_a_one_arm_cell_runs_five_services_in_start_order() -> None:
    assert list(specs()) == [
        "controller/0",
        "executor/0",
        "broadcaster/0",
        "interpolator/0",
        "gateway/0",
    ]


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


@pytest.mark.parametrize("gateway", ["gateway", "gateway/0"])
def test_skipped_services_are_left_out_named_either_way(gateway: str) -> None:
    names = list(specs(DUAL, skip=("interpolator/1", gateway)))
    assert "interpolator/1" not in names
    assert "gateway/0" not in names
    assert "interpolator/0" in names


def test_the_one_interpolator_of_a_one_group_cell_needs_no_group() -> None:
    assert "interpolator/0" not in specs(skip=("interpolator",))


def test_an_interpolator_of_a_cell_of_several_groups_must_be_named_with_its_group() -> None:
    with pytest.raises(UnknownServiceError, match=r"interpolator/0, interpolator/1, interp"):
        specs(DUAL, skip=("interpolator",))


def test_skipping_a_service_the_cell_lacks_names_what_it_has() -> None:
    with pytest.raises(UnknownServiceError, match=r"--skip: .*interpolator/3.*controller/0"):
        specs(DUAL, skip=("interpolator/3",))


def test_an_unknown_skip_is_refused_even_beside_a_known_one() -> None:
    with pytest.raises(UnknownServiceError, match="bogus"):
        specs(skip=("gateway", "bogus"))


# -- command lines ------------------------------------------------------------------------


def test_each_child_runs_its_service_module_connected_to_the_endpoint() -> None:
    for name, spec in specs().items():
        module = name.split("/")[0]
        assert spec.argv[:3] == (*PYTHON, f"motocell.services.{module}")
        assert spec.argv[spec.argv.index("--zenoh-connect") + 1] == ENDPOINT


def test_without_options_children_get_only_the_endpoint() -> None:
    assert argv() == [*PYTHON, "motocell.services.controller", "--zenoh-connect", ENDPOINT]


def test_config_name_and_credentials_go_to_every_child() -> None:
    options = UpOptions(config="cell.toml", name="left", credentials="/run/creds")
    for spec in specs(options=options).values():
        command = list(spec.argv)
        assert command[command.index("--config") + 1] == "cell.toml"
        assert command[command.index("--name") + 1] == "left"
        assert command[command.index("--credentials") + 1] == "/run/creds"


def test_on_a_new_bus_only_each_first_start_holds_its_claim_at_once() -> None:
    """A restart joins a bus others may have joined since: its claim settles (topology.md)."""
    for spec in specs(options=UpOptions(credentials="/run/creds", new_bus=True)).values():
        assert spec.argv_for(restart=False) == (*spec.argv, "--new-bus"), spec.name
        assert "--new-bus" not in spec.argv_for(restart=True), spec.name
    for spec in specs(options=UpOptions(credentials="/run/creds")).values():
        assert spec.argv_for(restart=False) == spec.argv == spec.argv_for(restart=True)


def test_port_options_go_to_the_services_that_serve_tcp_only() -> None:
    chosen = specs(options=UpOptions(host="0.0.0.0", port_base=50300, byte_order="big"))
    for name in ("gateway/0", "broadcaster/0"):
        argv = list(chosen[name].argv)
        assert argv[-6:] == ["--host", "0.0.0.0", "--port-base", "50300", "--byte-order", "big"]
    for name, spec in chosen.items():
        if name not in ("gateway/0", "broadcaster/0"):
            assert "--host" not in spec.argv
            assert "--port-base" not in spec.argv
