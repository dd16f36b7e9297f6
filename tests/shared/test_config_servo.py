"""The servo settings of models and groups: the catalogue's, a group's own, and the checks."""

from __future__ import annotations

from typing import Any

import pytest

from motocell.shared.config import (
    ConfigError,
    IdealServo,
    PositionLoop,
    load_catalogue,
    load_cell,
    parse_cell,
    sample_cells,
)


def group_servo(servo: dict[str, Any]) -> Any:
    return parse_cell({"groups": [{"servo": servo}]}).groups[0].servo


def test_every_catalogue_model_has_a_position_loop() -> None:
    for name, model in load_catalogue().items():
        assert isinstance(model.servo, PositionLoop), name


def test_the_sample_cells_and_the_default_cell_run_the_realistic_servo() -> None:
    for name in [*sample_cells(), None]:
        for group in load_cell(name).groups:
            assert group.servo == group.model.servo
            assert isinstance(group.servo, PositionLoop)


def test_a_group_may_pin_the_ideal_servo() -> None:
    assert group_servo({"kind": "ideal"}) == IdealServo()


def test_a_group_may_tune_its_position_loop() -> None:
    servo = group_servo({"kind": "position_loop", "gain": 80.0})
    assert servo == PositionLoop(gain=80.0, feed_forward=0.5, filter_ms=12.0)


def test_a_model_of_the_cell_file_without_a_servo_gets_the_default_loop() -> None:
    arm = load_catalogue()["arm6"]
    raw = {
        "models": {"mine": {f: getattr(arm, f) for f in arm.__struct_fields__ if f != "servo"}},
        "groups": [{"model": "mine"}],
    }
    assert parse_cell(raw).groups[0].servo == PositionLoop()


@pytest.mark.parametrize(
    ("servo", "message"),
    [
        ({"kind": "pid"}, "groups[0].servo.kind: Invalid value 'pid'"),
        ({"kind": "position_loop", "gain": 0}, "groups[0].servo.gain: 0.0 must be a number"),
        ({"kind": "position_loop", "gain": float("inf")}, "servo.gain: inf must be a number"),
        ({"kind": "position_loop", "feed_forward": 1.5}, "servo.feed_forward: 1.5 must be 0"),
        ({"kind": "position_loop", "filter_ms": -1}, "servo.filter_ms: -1.0 must be a number"),
        ({"kind": "position_loop", "gian": 3}, "unknown field `gian`; did you mean `gain`?"),
        ({"kind": "ideal", "gain": 3}, "groups[0].servo: Object contains unknown field `gain`"),
        ({"gain": 3}, "groups[0].servo: Object missing required field `kind`"),
    ],
)
def test_bad_servo_settings_name_the_field(servo: dict[str, Any], message: str) -> None:
    with pytest.raises(ConfigError) as error:
        group_servo(servo)
    assert message in str(error.value)


def test_a_misspelt_servo_field_of_a_model_gets_the_nearest_name() -> None:
    arm = load_catalogue()["arm6"]
    fields = {f: getattr(arm, f) for f in arm.__struct_fields__ if f != "servo"}
    fields["servo"] = {"kind": "position_loop", "feed_froward": 0.2}
    with pytest.raises(ConfigError, match="did you mean `feed_forward`"):
        parse_cell({"models": {"mine": fields}})
