"""One vocabulary for a cell's services: ``gateway/0`` as logs and ``motocell watch`` write it,
``gateway`` for short, an interpolator by its group."""

from __future__ import annotations

import pytest

from motocell.shared.config import load_cell, parse_cell
from motocell.shared.service import required_alive_keys
from motocell.shared.service_names import (
    ServiceName,
    UnknownServiceError,
    cell_services,
    parse_service,
    service_kind,
)

ONE_ARM = load_cell(None)
TWO_GROUPS = parse_cell(
    {"groups": [{"name": "R1", "model": "arm6"}, {"name": "S1", "model": "positioner2"}]}
)


def test_a_cell_has_each_service_once_and_an_interpolator_per_group_in_start_order() -> None:
    assert list(map(str, cell_services(TWO_GROUPS))) == [
        "controller/0",
        "executor/0",
        "broadcaster/0",
        "interpolator/0",
        "interpolator/1",
        "gateway/0",
    ]


@pytest.mark.parametrize("text", ["gateway", "gateway/0"])
def test_a_service_with_one_instance_is_named_either_way(text: str) -> None:
    assert parse_service(text, TWO_GROUPS) == ServiceName("gateway", "0")


def test_an_interpolator_is_named_by_its_group() -> None:
    assert parse_service("interpolator/1", TWO_GROUPS) == ServiceName("interpolator", "1")


def test_the_only_interpolator_of_a_one_group_cell_needs_no_group() -> None:
    assert parse_service("interpolator", ONE_ARM) == ServiceName("interpolator", "0")


def test_an_interpolator_of_a_cell_of_several_groups_needs_its_group() -> None:
    with pytest.raises(UnknownServiceError, match=r"one per group; name it: interpolator/0, "):
        parse_service("interpolator", TWO_GROUPS)


@pytest.mark.parametrize(
    ("text", "listed"),
    [
        ("interpolator/1", "interpolator/0, gateway/0"),
        ("bogus", "controller, executor, broadcaster, interpolator, gateway"),
        ("gateway/1", "a cell has one gateway, gateway/0"),
        ("interpolator/x", "interpolator/GROUP takes a group number"),
        ("interpolator/01", "interpolator/GROUP takes a group number"),
    ],
)
def test_a_name_that_is_no_service_of_the_cell_is_refused_with_what_there_is(
    text: str, listed: str
) -> None:
    with pytest.raises(UnknownServiceError, match=f"no service {text}.*{listed}"):
        parse_service(text, ONE_ARM)


def test_without_a_cell_the_kind_and_a_given_instance_are_told_apart() -> None:
    assert service_kind("gateway") == ("gateway", None)
    assert service_kind("interpolator/3") == ("interpolator", "3")


def test_the_ros2_face_is_a_service_only_of_a_cell_whose_file_asks_for_it() -> None:
    with_face = parse_cell({"ros2": {}})
    assert [str(name) for name in cell_services(with_face)][-1] == "ros2/0"
    assert parse_service("ros2", with_face) == ServiceName("ros2", "0")
    assert "ros2/0" not in map(str, cell_services(ONE_ARM))
    with pytest.raises(UnknownServiceError, match=r"no ROS 2 face: add a \[ros2\] table"):
        parse_service("ros2", ONE_ARM)


def test_a_cell_moves_without_its_ros2_face() -> None:
    """The controller waits for every service but the face: Simple Message clients never
    wait for it."""
    with_face = parse_cell({"name": "f", "ros2": {}})
    assert not any("/alive/ros2/" in key for key in required_alive_keys(with_face))
    assert len(required_alive_keys(with_face)) == len(cell_services(with_face)) - 1
