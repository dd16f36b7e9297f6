"""Cell files and the robot model catalogue: the samples load, the default needs no file, and
bad files are refused with a message that names the field and the problem."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from motocell.shared.config import (
    DEFAULT_START_BUFFER_PERIODS,
    LOOK_AHEAD_POINTS,
    MAX_PENDING_POINTS,
    MAX_START_BUFFER_PERIODS,
    PROFILES,
    Cell,
    ConfigError,
    ControllerModel,
    load_catalogue,
    load_cell,
    sample_cells,
)
from motocell.shared.files import CELL_FILE_LIMIT
from motocell.shared.protocol.constants import MAX_AXES

REPO = Path(__file__).resolve().parents[2]
CELLS = REPO / "shared" / "cells"

CATALOGUE_NAMES = ("arm6", "arm7", "positioner2", "track1")


def write_cell(tmp_path: Path, text: str, name: str = "cell.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def refused(tmp_path: Path, text: str) -> str:
    """Load ``text`` as a cell file, expect ConfigError, return its message."""
    path = write_cell(tmp_path, text)
    with pytest.raises(ConfigError) as info:
        load_cell(path)
    message = str(info.value)
    assert message.startswith(str(path)), message
    return message


def groups_toml(*models: str) -> str:
    return "".join(
        f'[[groups]]\nname = "G{i}"\nmodel = "{model}"\n\n' for i, model in enumerate(models)
    )


def custom_model(
    axes: int = 2,
    *,
    axis_types: int | None = None,
    pulses: list[float] | None = None,
    pulses_count: int | None = None,
    seven_axis: bool = False,
) -> str:
    """A ``[models.x]`` table; each list has ``axes`` entries unless overridden."""
    n_types = axes if axis_types is None else axis_types
    pulses_values = pulses if pulses is not None else [1000.0] * (pulses_count or axes)
    lines = [
        "[models.x]",
        'kind = "robot"',
        f"axis_types = {['rotary'] * n_types}".replace("'", '"'),
        f"pulses_per_unit = {pulses_values}",
        f"max_speed = {[1.0] * axes}",
        f"max_accel = {[2.0] * axes}",
        f"initial_position = {[0.0] * axes}",
        f"joint_limits = {[[-1.0, 1.0]] * axes}",
        f"dh = {[[0.0, 0.0, 0.0, 0.0]] * min(axes, MAX_AXES)}",
    ]
    if seven_axis:
        lines.append("seven_axis = true")
    return "\n".join(lines) + "\n"


# --- the sample cells ---------------------------------------------------------------------


@dataclass(frozen=True)
class Expected:
    name: str
    controller: ControllerModel
    groups: tuple[tuple[str, str, int], ...]  # (group name, model, axes)
    byte_order: str = "little"
    port_base: int = 50240
    period_ns: int = 4_000_000
    state_period_ns: int = 10_000_000


SAMPLES = {
    "single-arm.toml": Expected("cell1", ControllerModel.YRC1000, (("R1", "arm6", 6),)),
    "fs100.toml": Expected("fs100", ControllerModel.FS100, (("R1", "arm6", 6),), "big"),
    "dual-arm-positioner.toml": Expected(
        "dual",
        ControllerModel.YRC1000,
        (("R1", "arm6", 6), ("R2", "arm7", 7), ("S1", "positioner2", 2)),
    ),
    "four-group.toml": Expected(
        "four",
        ControllerModel.YRC1000,
        (("R1", "arm6", 6), ("R2", "arm6", 6), ("B1", "track1", 1), ("S1", "positioner2", 2)),
    ),
}


def test_every_sample_cell_is_covered() -> None:
    assert sorted(p.name for p in CELLS.glob("*.toml")) == sorted(SAMPLES)


@pytest.mark.parametrize("file_name", sorted(SAMPLES))
def test_sample_cell_loads(file_name: str) -> None:
    expected = SAMPLES[file_name]
    cell = load_cell(CELLS / file_name)
    assert cell.name == expected.name
    assert cell.controller is expected.controller
    assert cell.byte_order == expected.byte_order
    assert len(cell.groups) == len(expected.groups)
    assert [(g.name, g.model_name, g.axes) for g in cell.groups] == list(expected.groups)
    assert [g.index for g in cell.groups] == list(range(len(expected.groups)))
    for group in cell.groups:
        assert len(group.initial_position) == group.axes
    assert cell.port_base == expected.port_base
    assert (cell.motion_port, cell.state_port, cell.io_port) == (
        expected.port_base,
        expected.port_base + 1,
        expected.port_base + 2,
    )
    assert cell.period_ns == expected.period_ns
    assert cell.state_period_ns == expected.state_period_ns
    assert cell.period_s == pytest.approx(expected.period_ns / 1e9)


def test_group_initial_position_overrides_the_model() -> None:
    cell = load_cell(CELLS / "dual-arm-positioner.toml")
    assert cell.groups[1].initial_position == (0.0, 0.3, 0.0, -0.5, 0.0, 0.4, 0.0)
    assert cell.groups[0].initial_position == (0.0,) * 6


def test_default_cell_needs_no_file() -> None:
    cell = load_cell(None)
    assert isinstance(cell, Cell)
    assert cell.name == "cell1"
    assert cell.controller is ControllerModel.YRC1000
    assert cell.byte_order == "little"
    assert [(g.index, g.name, g.model_name, g.axes) for g in cell.groups] == [(0, "R1", "arm6", 6)]
    assert cell.groups[0].model.kind == "robot"
    assert cell.period_ns == 4_000_000
    assert cell.state_period_ns == 10_000_000
    assert (cell.host, cell.port_base) == ("127.0.0.1", 50240)
    assert (cell.motion_port, cell.state_port, cell.io_port) == (50240, 50241, 50242)


def test_default_equals_the_single_arm_sample() -> None:
    assert load_cell(None) == load_cell(CELLS / "single-arm.toml")


def test_empty_file_gives_the_default(tmp_path: Path) -> None:
    assert load_cell(write_cell(tmp_path, "")) == load_cell(None)


@pytest.mark.parametrize("controller", list(ControllerModel))
def test_byte_order_follows_the_controller(tmp_path: Path, controller: ControllerModel) -> None:
    cell = load_cell(write_cell(tmp_path, f'controller = "{controller.value}"\n'))
    assert cell.controller is controller
    assert cell.byte_order == ("big" if controller is ControllerModel.FS100 else "little")
    assert cell.byte_order == PROFILES[controller].byte_order


def test_byte_order_can_be_overridden(tmp_path: Path) -> None:
    text = 'controller = "FS100"\nbyte_order = "little"\n'
    assert load_cell(write_cell(tmp_path, text)).byte_order == "little"


def test_group_limits_accept_the_maximum(tmp_path: Path) -> None:
    dx100 = f'controller = "DX100"\n{groups_toml("arm6", "arm6", "track1")}'
    assert len(load_cell(write_cell(tmp_path, dx100, "dx100.toml")).groups) == 3
    yrc = f'controller = "YRC1000"\n{groups_toml("arm6", "arm6", "track1", "positioner2")}'
    assert len(load_cell(write_cell(tmp_path, yrc, "yrc.toml")).groups) == 4


def test_custom_model_can_be_used_by_a_group(tmp_path: Path) -> None:
    text = f'{custom_model(2)}\n[[groups]]\nname = "S1"\nmodel = "x"\n'
    cell = load_cell(write_cell(tmp_path, text))
    assert cell.groups[0].model_name == "x"
    assert cell.groups[0].axes == 2
    assert cell.groups[0].initial_position == (0.0, 0.0)


def test_periods_in_range_are_accepted(tmp_path: Path) -> None:
    text = "interpolation_period_ms = 0.5\nstate_period_ms = 0.5\n"
    cell = load_cell(write_cell(tmp_path, text))
    assert (cell.period_ns, cell.state_period_ns) == (500_000, 500_000)


def test_the_lateness_bound_is_three_periods_unless_set(tmp_path: Path) -> None:
    assert load_cell().max_lateness_periods == 25
    cell = load_cell(write_cell(tmp_path, "max_lateness_periods = 10\n"))
    assert cell.max_lateness_periods == 10


def test_one_pending_point_as_motoros_unless_set(tmp_path: Path) -> None:
    default = load_cell()
    assert default.pending_points == 1
    assert default.points_outstanding == LOOK_AHEAD_POINTS
    deepest = load_cell(write_cell(tmp_path, f"pending_points = {MAX_PENDING_POINTS}\n"))
    assert deepest.pending_points == deepest.points_outstanding == MAX_PENDING_POINTS


def test_a_sample_cell_is_named_without_its_path() -> None:
    """So the samples work from an installed wheel (``motocell up --config four-group``)."""
    assert sample_cells() == sorted(p.stem for p in CELLS.glob("*.toml"))
    assert load_cell("four-group") == load_cell(CELLS / "four-group.toml")


def test_a_name_that_is_neither_a_file_nor_a_sample_lists_the_samples() -> None:
    with pytest.raises(
        ConfigError, match=r"nosuch: no such file, nor a sample cell \(samples: dual"
    ):
        load_cell("nosuch")


def test_a_start_buffer_of_3_periods_unless_set(tmp_path: Path) -> None:
    assert load_cell().start_buffer_periods == DEFAULT_START_BUFFER_PERIODS == 3
    cell = load_cell(write_cell(tmp_path, "start_buffer_periods = 0\n"))
    assert cell.start_buffer_periods == 0


def test_tools_are_all_zero_unless_listed(tmp_path: Path) -> None:
    """Tool files from tool 0 on, one table for the cell; an unlisted tool is the flange."""
    assert load_cell().tool(0) == load_cell().tool(63) == (0.0,) * 6
    cell = load_cell(write_cell(tmp_path, "tools = [[0, 0, 0, 0, 0, 0], [0, 0, 0.2, 0, 0, 1.5]]\n"))
    assert cell.tool(1) == (0.0, 0.0, 0.2, 0.0, 0.0, 1.5)
    assert cell.tool(2) == (0.0,) * 6


@pytest.mark.parametrize("number", [-1, -2, 64])
def test_a_tool_number_a_controller_has_not_is_refused(tmp_path: Path, number: int) -> None:
    """-1 would otherwise be the last tool listed."""
    cell = load_cell(write_cell(tmp_path, "tools = [[0, 0, 0, 0, 0, 0], [0, 0, 0.2, 0, 0, 1.5]]\n"))
    with pytest.raises(ValueError, match="tools 0 to 63"):
        cell.tool(number)


# --- the catalogue ------------------------------------------------------------------------


def test_catalogue_models() -> None:
    catalogue = load_catalogue()
    assert set(catalogue) >= set(CATALOGUE_NAMES)

    arm6 = catalogue["arm6"]
    assert (arm6.axes, arm6.kind, arm6.seven_axis) == (6, "robot", False)
    assert set(arm6.axis_types) == {"rotary"}

    arm7 = catalogue["arm7"]
    assert (arm7.axes, arm7.kind, arm7.seven_axis) == (7, "robot", True)
    assert set(arm7.axis_types) == {"rotary"}

    positioner = catalogue["positioner2"]
    assert (positioner.axes, positioner.kind, positioner.seven_axis) == (2, "station", False)

    track = catalogue["track1"]
    assert (track.axes, track.kind, track.seven_axis) == (1, "base", False)
    assert track.axis_types == ["linear"]


@pytest.mark.parametrize("model_name", CATALOGUE_NAMES)
def test_catalogue_lists_are_consistent(model_name: str) -> None:
    model = load_catalogue()[model_name]
    n = model.axes
    assert 1 <= n <= MAX_AXES
    for values in (model.pulses_per_unit, model.max_speed, model.max_accel):
        assert len(values) == n
        assert all(math.isfinite(v) and v > 0 for v in values)
    assert len(model.initial_position) == n
    assert all(math.isfinite(v) for v in model.initial_position)
    assert len(model.dh) == n
    assert all(len(link) == 4 for link in model.dh)
    assert model.description


GP7_DEGREES = [(-170, 170), (-65, 145), (-70, 190), (-190, 190), (-135, 135), (-360, 360)]
SIA10_DEGREES = [(-180, 180), (-110, 110), (-170, 170), (-135, 135), (-180, 180), (-110, 110)]


@pytest.mark.parametrize(
    ("model_name", "degrees"),
    [("arm6", GP7_DEGREES), ("arm7", [*SIA10_DEGREES, (-180, 180)])],
)
def test_arm_ranges_are_those_of_the_real_model(
    model_name: str, degrees: list[tuple[int, int]]
) -> None:
    limits = load_catalogue()[model_name].joint_limits
    found = [math.degrees(value) for pair in limits for value in pair]
    assert found == pytest.approx([value for pair in degrees for value in pair], abs=0.01)


@pytest.mark.parametrize("model_name", CATALOGUE_NAMES)
def test_every_model_has_a_range_holding_its_initial_position(model_name: str) -> None:
    model = load_catalogue()[model_name]
    assert len(model.joint_limits) == model.axes
    for value, (lower, upper) in zip(model.initial_position, model.joint_limits, strict=True):
        assert lower < upper
        assert lower <= value <= upper


def test_a_group_takes_the_model_ranges_by_default() -> None:
    cell = load_cell()
    assert cell.groups[0].joint_limits == load_catalogue()["arm6"].ranges


def test_a_cell_file_narrows_the_ranges(tmp_path: Path) -> None:
    narrow = [[-1.0, 1.0], [-0.5, 0.5], [0.0, 0.1], [-2.0, 2.0], [-1.0, 1.0], [-3.0, 3.0]]
    cell = load_cell(write_cell(tmp_path, f'[[groups]]\nmodel = "arm6"\njoint_limits = {narrow}\n'))
    assert cell.groups[0].joint_limits == tuple(tuple(pair) for pair in narrow)


def test_widening_a_range_is_refused(tmp_path: Path) -> None:
    wide = [[-1.0, 1.0]] * 5 + [[-7.0, 1.0]]
    message = refused(tmp_path, f'[[groups]]\nmodel = "arm6"\njoint_limits = {wide}\n')
    assert "groups[0].joint_limits[5]" in message
    assert "widens" in message


@pytest.mark.parametrize(
    ("limits", "problem"),
    [
        ([[-1.0, 1.0]] * 5, "needs 6 [lower, upper] pairs"),
        ([[-1.0, 1.0, 2.0]] * 6, "needs 6 [lower, upper] pairs"),
        ([[1.0, -1.0]] * 6, "is not a finite range"),
    ],
)
def test_malformed_group_ranges_are_refused(
    tmp_path: Path, limits: list[list[float]], problem: str
) -> None:
    message = refused(tmp_path, f'[[groups]]\nmodel = "arm6"\njoint_limits = {limits}\n')
    assert "groups[0].joint_limits" in message
    assert problem in message


def test_an_initial_position_outside_the_range_is_refused(tmp_path: Path) -> None:
    text = '[[groups]]\nmodel = "arm6"\ninitial_position = [3.0, 0.0, 0.0, 0.0, 0.0, 0.0]\n'
    message = refused(tmp_path, text)
    assert "groups[0].initial_position[0]: 3.0 is outside the range" in message


def test_an_initial_position_outside_a_narrowed_range_is_refused(tmp_path: Path) -> None:
    text = '[[groups]]\nmodel = "track1"\njoint_limits = [[0.5, 1.0]]\n'
    assert "groups[0].initial_position[0]" in refused(tmp_path, text)


def test_a_model_whose_initial_position_is_outside_its_range_is_refused(tmp_path: Path) -> None:
    text = custom_model().replace("initial_position = [0.0, 0.0]", "initial_position = [0.0, 2.0]")
    assert "models.x.initial_position[1]" in refused(tmp_path, text + groups_toml("arm6"))


# --- bad files ----------------------------------------------------------------------------

BAD_FILES: dict[str, tuple[str, tuple[str, ...]]] = {
    "unknown top-level key": ("colour = 1\n", ("unknown field", "`colour`")),
    "wrong type": ('port_base = "x"\n', ("port_base", "Expected `int`, got `str`")),
    "wrong type in a group": (
        "[[groups]]\nname = 1\n",
        ("groups[0].name", "Expected `str`, got `int`"),
    ),
    "unknown key in a group": (
        '[[groups]]\nname = "R1"\nspeed = 3\n',
        ("groups[0]", "unknown field", "`speed`"),
    ),
    "unknown controller": ('controller = "YRC2000"\n', ("controller", "'YRC2000'", "Invalid")),
    "unknown byte order": ('byte_order = "middle"\n', ("byte_order", "'middle'")),
    "port_base out of range": ("port_base = 65534\n", ("port_base", "must be 1 to 65533")),
    "too many groups for DX100": (
        f'controller = "DX100"\n{groups_toml("arm6", "arm6", "track1", "positioner2")}',
        ("groups", "4 groups", "DX100", "1 to 3"),
    ),
    "too many groups for YRC1000": (
        f'controller = "YRC1000"\n{groups_toml("arm6", "arm6", "arm6", "track1", "positioner2")}',
        ("groups", "5 groups", "YRC1000", "1 to 4"),
    ),
    "zero groups": ("groups = []\n", ("groups", "0 groups", "1 to 4")),
    "duplicate group names": (
        '[[groups]]\nname = "R1"\n\n[[groups]]\nname = "R1"\nmodel = "arm7"\n',
        ("groups[1].name", "'R1'", "used twice"),
    ),
    "unknown model": (
        '[[groups]]\nname = "R1"\nmodel = "arm9"\n',
        ("groups[0].model", "unknown model 'arm9'", "known:", *CATALOGUE_NAMES),
    ),
    "initial_position too short": (
        '[[groups]]\nmodel = "arm6"\ninitial_position = [0.0, 0.0, 0.0]\n',
        ("groups[0].initial_position", "needs 6 finite values"),
    ),
    "initial_position too long": (
        '[[groups]]\nmodel = "track1"\ninitial_position = [0.0, 0.0]\n',
        ("groups[0].initial_position", "needs 1 finite values"),
    ),
    "initial_position nan": (
        '[[groups]]\nmodel = "positioner2"\ninitial_position = [nan, 0.0]\n',
        ("groups[0].initial_position", "needs 2 finite values"),
    ),
    "initial_position inf": (
        '[[groups]]\nmodel = "positioner2"\ninitial_position = [0.0, -inf]\n',
        ("groups[0].initial_position", "needs 2 finite values"),
    ),
    "interpolation period too short": (
        "interpolation_period_ms = 0.1\n",
        ("interpolation_period_ms", "must be 0.5 to 100"),
    ),
    "interpolation period too long": (
        "interpolation_period_ms = 200\nstate_period_ms = 500\n",
        ("interpolation_period_ms", "must be 0.5 to 100"),
    ),
    "interpolation period zero": (
        "interpolation_period_ms = 0\n",
        ("interpolation_period_ms", "must be 0.5 to 100"),
    ),
    "state period shorter than a period": (
        "interpolation_period_ms = 8\nstate_period_ms = 4\n",
        ("state_period_ms", "from one interpolation period"),
    ),
    "state period too long": (
        "state_period_ms = 2000\n",
        ("state_period_ms", "to 1000"),
    ),
    "no lateness allowed": (
        "max_lateness_periods = 0\n",
        ("max_lateness_periods", "must be 1 to 1000"),
    ),
    "no pending point": (
        "pending_points = 0\n",
        ("pending_points", f"must be 1 to {MAX_PENDING_POINTS}"),
    ),
    "too many pending points": (
        f"pending_points = {MAX_PENDING_POINTS + 1}\n",
        ("pending_points", f"must be 1 to {MAX_PENDING_POINTS}"),
    ),
    "negative start buffer": (
        "start_buffer_periods = -1\n",
        ("start_buffer_periods", f"must be 0 to {MAX_START_BUFFER_PERIODS}"),
    ),
    "start buffer too long": (
        f"start_buffer_periods = {MAX_START_BUFFER_PERIODS + 1}\n",
        ("start_buffer_periods", f"must be 0 to {MAX_START_BUFFER_PERIODS}"),
    ),
    "a tool with 5 values": (
        "tools = [[0, 0, 0.1, 0, 0]]\n",
        ("tools[0]", "needs 6 finite values [x, y, z, rx, ry, rz]"),
    ),
    "a tool not finite": (
        "tools = [[0, 0, 0, 0, 0, 0], [0, 0, nan, 0, 0, 0]]\n",
        ("tools[1]", "needs 6 finite values"),
    ),
    "more tools than a controller has": (
        f"tools = [{', '.join(['[0, 0, 0, 0, 0, 0]'] * 65)}]\n",
        ("tools", "65 tools, a controller has 64"),
    ),
    "bad cell name": ('name = "a/b"\n', ("name", "'a/b'", "letters, digits, - or _")),
    "empty cell name": ('name = ""\n', ("name", "''", "letters, digits, - or _")),
    "custom model list lengths differ": (
        custom_model(2, pulses_count=1),
        ("models.x.pulses_per_unit", "1 values for 2 axes"),
    ),
    "custom model with 9 axes": (
        custom_model(9),
        ("models.x.axis_types", "9 axes", f"1 to {MAX_AXES}"),
    ),
    "custom model with no axes": (
        custom_model(0),
        ("models.x.axis_types", "0 axes"),
    ),
    "seven_axis on a 6-axis model": (
        custom_model(6, seven_axis=True),
        ("models.x.seven_axis", "6 axes, not 7"),
    ),
    "zero pulses_per_unit": (
        custom_model(2, pulses=[1000.0, 0.0]),
        ("models.x.pulses_per_unit", "must be > 0"),
    ),
    "negative pulses_per_unit": (
        custom_model(2, pulses=[-1.0, 1000.0]),
        ("models.x.pulses_per_unit", "must be > 0"),
    ),
    "non-finite pulses_per_unit": (
        custom_model(2, pulses=[1000.0, math.inf]),
        ("models.x.pulses_per_unit", "finite"),
    ),
    "models not a table": ("models = 1\n", ("models", "must be a table")),
    "not valid TOML": ("name = \n", ("not valid TOML",)),
    "duplicate TOML key": ('name = "a"\nname = "b"\n', ("not valid TOML",)),
}


@pytest.mark.parametrize("case", sorted(BAD_FILES))
def test_bad_file_is_refused(tmp_path: Path, case: str) -> None:
    text, fragments = BAD_FILES[case]
    message = refused(tmp_path, text)
    for fragment in fragments:
        assert fragment in message, f"{fragment!r} not in {message!r}"


def test_unused_bad_custom_model_is_refused(
    tmp_path: Path,
) -> None:
    # A bad custom model is refused even when no group uses it.
    text = f'{custom_model(2, pulses_count=3)}\n[[groups]]\nmodel = "arm6"\n'
    assert "models.x.pulses_per_unit" in refused(tmp_path, text)


def test_missing_file_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "nope.toml"
    with pytest.raises(ConfigError) as info:
        load_cell(path)
    message = str(info.value)
    assert str(path) in message
    assert "cannot read" in message
    assert "No such file" in message


def test_directory_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="is not a regular file \\(a directory\\)"):
        load_cell(tmp_path)


def test_a_device_is_refused_without_reading_it() -> None:
    with pytest.raises(ConfigError, match="/dev/zero is not a regular file \\(a device\\)"):
        load_cell("/dev/zero")


def test_a_fifo_is_refused_without_waiting_for_a_writer(tmp_path: Path) -> None:
    fifo = tmp_path / "cell.toml"
    os.mkfifo(fifo)
    with pytest.raises(ConfigError, match="is not a regular file \\(a FIFO\\)"):
        load_cell(fifo)


def test_a_binary_file_is_one_line(tmp_path: Path) -> None:
    path = tmp_path / "cell.toml"
    path.write_bytes(b'name = "x"\n\xff\xfe\x00')
    with pytest.raises(ConfigError) as info:
        load_cell(path)
    assert str(info.value) == (
        f"cell file {path} is not a text file (no UTF-8 at byte 11): not the file meant?"
    )


def test_a_file_one_byte_beyond_the_limit_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "cell.toml"
    path.write_bytes(b"#" * CELL_FILE_LIMIT)
    assert load_cell(path) == load_cell(None)  # a comment alone, at exactly the limit
    with path.open("ab") as grown:
        grown.write(b"#")
    with pytest.raises(ConfigError, match="is larger than 1 MiB"):
        load_cell(path)


# --- edge cases: empty and non-finite values, wording, misspelt fields, placement ---------


def test_empty_initial_position_is_refused(tmp_path: Path) -> None:
    message = refused(tmp_path, '[[groups]]\nmodel = "arm6"\ninitial_position = []\n')
    assert "groups[0].initial_position" in message


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ("interpolation_period_ms = nan\n", "interpolation_period_ms"),
        ("interpolation_period_ms = inf\n", "interpolation_period_ms"),
        ("state_period_ms = nan\n", "state_period_ms"),
        ("state_period_ms = inf\n", "state_period_ms"),
    ],
)
def test_non_finite_period_is_refused(tmp_path: Path, text: str, field: str) -> None:
    assert field in refused(tmp_path, text)


def test_custom_model_decode_error_names_the_model(tmp_path: Path) -> None:
    message = refused(tmp_path, '[models.x]\nkind = "robot"\n')
    assert "axis_types" in message
    assert "models.x" in message


def test_unknown_top_level_key_message_is_well_formed(tmp_path: Path) -> None:
    assert ": :" not in refused(tmp_path, "colour = 1\n")


@pytest.mark.parametrize(
    ("text", "suggestion"),
    [
        ('nmae = "x"\n', "`nmae`; did you mean `name`?"),
        ("state_period = 10\n", "did you mean `state_period_ms`?"),
        ('[[groups]]\nmodle = "arm6"\n', "groups[0]: Object contains unknown field `modle`; "),
        ("[zenoh]\nconect = []\n", "zenoh: Object contains unknown field `conect`; did you"),
        ('[models.x]\nkind = "robot"\naxis_typs = []\n', "did you mean `axis_types`?"),
        ("[[groups]]\nbsae = {}\n", "did you mean `base`?"),
        ("[[groups]]\nbase = { xzy = [0, 0, 0] }\n", "groups[0].base: Object contains unknown"),
        ("[[groups]]\nbase = { xzy = [0, 0, 0] }\n", "did you mean `xyz`?"),
    ],
)
def test_a_misspelt_field_gets_the_nearest_one_of_its_table(
    tmp_path: Path, text: str, suggestion: str
) -> None:
    assert suggestion in refused(tmp_path, text)


@pytest.mark.parametrize(
    ("text", "choices"),
    [
        (
            'controller = "YRC9000"\n',
            "controller: Invalid enum value 'YRC9000'; one of: DX100, FS100",
        ),
        ('byte_order = "middle"\n', "byte_order: Invalid enum value 'middle'; one of: little, big"),
        ('[[groups]]\nmodel = "arm6"\nservo = { kind = "nope" }\n', "groups[0].servo.kind"),
    ],
)
def test_a_value_a_field_does_not_take_lists_the_ones_it_does(
    tmp_path: Path, text: str, choices: str
) -> None:
    assert choices in refused(tmp_path, text)


def test_a_field_like_no_other_gets_no_suggestion(tmp_path: Path) -> None:
    assert "did you mean" not in refused(tmp_path, "colour = 1\n")


def test_a_group_stands_at_the_cells_origin_unless_placed(tmp_path: Path) -> None:
    assert (load_cell().groups[0].base.xyz, load_cell().groups[0].base.rpy) == ([0, 0, 0],) * 2
    text = '[[groups]]\nmodel = "arm6"\nbase = { xyz = [1.0, -0.5, 0.2], rpy = [0, 0, 1.57] }\n'
    base = load_cell(write_cell(tmp_path, text)).groups[0].base
    assert (base.xyz, base.rpy) == ([1.0, -0.5, 0.2], [0, 0, 1.57])


@pytest.mark.parametrize(
    "base", ["{ xyz = [1.0, 2.0] }", "{ rpy = [0, 0, 0, 1] }", "{ xyz = [nan, 0, 0] }"]
)
def test_a_placement_needs_three_finite_values(tmp_path: Path, base: str) -> None:
    message = refused(tmp_path, f'[[groups]]\nmodel = "arm6"\nbase = {base}\n')
    assert "groups[0].base." in message and "needs 3 finite values" in message


# --- motocell up ----------------------------------------------------------------------------


REFUSAL_DEADLINE_S = 90.0
"""A hang, not a slow start: an interpreter and its imports take seconds on a loaded machine.
How fast `motocell up` starts and stops is benchmark figure 9."""


@pytest.mark.cell
def test_up_refuses_a_bad_file_with_status_2(tmp_path: Path) -> None:
    """Refused before it starts anything: one line, and nothing else."""
    path = write_cell(tmp_path, '[[groups]]\nname = "R1"\nmodel = "arm9"\n')
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "motocell.tools.cli",
            "up",
            "--config",
            str(path),
            "--port-base",
            "1",
            "--zenoh-listen",
            "tcp/127.0.0.1:1",
        ],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=REFUSAL_DEADLINE_S,
        check=False,
    )
    assert result.returncode == 2, result.stderr
    assert "groups[0].model" in result.stderr
    assert "unknown model 'arm9'" in result.stderr
    assert str(path) in result.stderr
    assert "Traceback" not in result.stderr
    assert result.stdout == ""
    assert result.stderr.count("\n") == 1, result.stderr
