"""Cell configuration: one TOML file, decoded into typed structs, with defaults that need no file.

A cell is one controller: its model (byte order, group limit), interpolation period, ports,
state period, Zenoh endpoints and up to four control groups, each naming a robot model from the
catalogue in ``models.toml``. Bad files are refused with a message naming the field.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import re
import tomllib
import types
import typing
from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum, StrEnum
from pathlib import Path
from typing import Any, Literal

import msgspec

from motocell.shared.files import CELL_FILE_LIMIT, FileRefusedError, read_text_bounded
from motocell.shared.protocol.constants import MAX_AXES, TOOL_NUMBERS

DEFAULT_MAX_LATENESS_PERIODS = 25
"""100 ms at 4 ms. Far shorter than the 0.4-0.5 s after which a client can be told NOT_READY
(so nothing queued before NOT_READY ever moves), and far longer than the executor's real
jitter on a shared 2-core machine, with SCHED_FIFO or without, which a 3-period bound turns
into false alarms (measured: docs/behaviour.md, Stalls, and docs/realtime.md,
Why SCHED_FIFO)."""

MAX_PENDING_POINTS = 32
"""The deepest pending-point FIFO a cell file may ask for (``pending_points``): ample for a
client that streams a few points ahead (32 points 4 ms apart are 128 ms of motion), and a bound
on what each interpolator holds."""
DEFAULT_START_BUFFER_PERIODS = 3
"""12 ms at 4 ms: the start buffer of a cell file that does not set one. Enough for a client that
streams without look-ahead to leave no period empty (figure 5, measured: docs/behaviour.md,
Start buffer); no client can see 12 ms more before the first move."""
MAX_START_BUFFER_PERIODS = 50
"""The longest start buffer a cell file may ask for (``start_buffer_periods``): 200 ms at 4 ms,
far beyond any latency a client's stream should have to absorb."""
LOOK_AHEAD_POINTS = 3
"""Points the gateway may have outstanding per group, whatever ``pending_points`` says, while
their segments all fit the executor's ring together (``GroupCredit.pending_fits``)."""


SHARED = Path(__file__).parent
"""``motocell.shared``'s folder, which holds its package data (``models.toml``, the sample
cells): read as files, not through ``importlib.resources``, which with the ``tempfile``,
``shutil`` and ``zipfile`` it brings is 5-8 ms of CPU in the launcher and in the warm parent
at every cell's start (docs/startup.md), for packages motocell is never installed as (a zip)."""
SAMPLE_CELLS = SHARED / "cells"
"""The sample cell files (package data)."""

EXIT_CONFIG = 2
"""The exit status of a process that cannot start as configured (a bad file or option, refused
credentials, a taken name): restarting it would not help, so the launcher stops the cell."""
MAX_PORT = 65535
"""The highest TCP port: a cell's port base leaves room for its state and I/O ports below it."""
PORT_COUNT = 3
"""A cell's consecutive TCP ports from its port base: motion, state, I/O (``Cell``)."""
MAX_PORT_BASE = MAX_PORT - PORT_COUNT + 1


class ConfigError(ValueError):
    """A cell or model file that cannot be used; the message names the field and the problem."""


class ControllerModel(StrEnum):
    DX100 = "DX100"
    FS100 = "FS100"
    DX200 = "DX200"
    YRC1000 = "YRC1000"
    YRC1000MICRO = "YRC1000micro"


@dataclass(frozen=True)
class ControllerProfile:
    byte_order: Literal["little", "big"]
    max_groups: int


# FS100 is PowerPC and so big-endian; the others are x86 (motoros1 §1.1).
# DX100 caps the group count at 3 (motoros1 §0 step 5).
PROFILES: dict[ControllerModel, ControllerProfile] = {
    ControllerModel.DX100: ControllerProfile("little", 3),
    ControllerModel.FS100: ControllerProfile("big", 4),
    ControllerModel.DX200: ControllerProfile("little", 4),
    ControllerModel.YRC1000: ControllerProfile("little", 4),
    ControllerModel.YRC1000MICRO: ControllerProfile("little", 4),
}


class IdealServo(
    msgspec.Struct, frozen=True, forbid_unknown_fields=True, tag="ideal", tag_field="kind"
):
    """Feedback is the commanded position at the end of every period: no following error,
    stops in one period. For tests and benchmarks that check exact feedback during motion."""


class PositionLoop(
    msgspec.Struct, frozen=True, forbid_unknown_fields=True, tag="position_loop", tag_field="kind"
):
    """A position loop with velocity feed-forward behind a first-order command filter, as
    industrial servo drives run (``shared.motion.servo`` steps it; docs/servo.md derives it and
    the defaults, a lag of about 22 ms behind a steady command)."""

    gain: float = 40.0
    """Position loop gain, 1/s: the error left after a stop decays as exp(-gain * t)."""
    feed_forward: float = 0.5
    """Velocity feed-forward, 0 to 1: the share of the commanded velocity fed past the loop;
    1 leaves only the filter's lag, 0 is a plain proportional loop."""
    filter_ms: float = 12.0
    """Time constant of the first-order command filter ahead of the loop (the controller's
    command smoothing), ms; 0 for none. It keeps the feedback's velocity continuous at a
    stop."""


ServoSettings = IdealServo | PositionLoop
"""What a robot model's or a group's ``servo`` table decodes to (``kind`` chooses)."""


class RobotModel(msgspec.Struct, frozen=True, forbid_unknown_fields=True):
    """One mechanism type. Lists are in ROS joint order."""

    kind: Literal["robot", "base", "station"]
    axis_types: list[Literal["rotary", "linear"]]
    pulses_per_unit: list[float]
    max_speed: list[float]
    max_accel: list[float]
    initial_position: list[float]
    joint_limits: list[list[float]]
    """[lower, upper] per axis: the controller's motion range (soft limits)."""
    dh: list[list[float]]
    seven_axis: bool = False
    description: str = ""
    servo: ServoSettings = msgspec.field(default_factory=PositionLoop)
    """How each axis's feedback follows its command (``shared.motion.servo``, docs/servo.md)."""

    @property
    def axes(self) -> int:
        return len(self.axis_types)

    @property
    def ranges(self) -> tuple[tuple[float, float], ...]:
        """``joint_limits`` as the (lower, upper) pairs a ``Group`` holds."""
        return tuple((lower, upper) for lower, upper in self.joint_limits)


class Placement(msgspec.Struct, frozen=True, forbid_unknown_fields=True):
    """Where a group's base frame sits in the cell's frame (z up), as URDF writes an origin."""

    xyz: list[float] = msgspec.field(default_factory=lambda: [0.0, 0.0, 0.0])
    """Metres."""
    rpy: list[float] = msgspec.field(default_factory=lambda: [0.0, 0.0, 0.0])
    """Roll, pitch, yaw in radians about the cell's fixed axes: R = Rz(yaw) Ry(pitch) Rx(roll)."""


class GroupConfig(msgspec.Struct, frozen=True, forbid_unknown_fields=True):
    name: str = "R1"
    model: str = "arm6"
    initial_position: list[float] | None = None
    """Overrides the model's initial position (ROS order)."""
    joint_limits: list[list[float]] | None = None
    """Narrows the model's joint ranges ([lower, upper] per axis, ROS order); never widens."""
    base: Placement = msgspec.field(default_factory=Placement)
    """Where the group stands in the cell (``motocell view`` draws it there); the cell's origin
    unless set."""
    servo: ServoSettings | None = None
    """Replaces the model's servo for this group (``{ kind = "ideal" }``: feedback = command)."""


class ZenohConfig(msgspec.Struct, frozen=True, forbid_unknown_fields=True):
    connect: list[str] = msgspec.field(default_factory=list)
    """The router the services join (``--zenoh-connect`` overrides it). Services are always
    clients of a router: a peer's own listener would let anyone deliver samples to it
    directly, past the router's access control."""


class UpdatePeriods(msgspec.Struct, frozen=True, forbid_unknown_fields=True):
    """MotoROS2's ``update_periods`` that apply to the face, milliseconds."""

    controller_status_monitor_period: int = 10
    """How often ``joint_states``, ``robot_status`` and ``tf`` are published (100 Hz)."""
    action_feedback_publisher_period: int = 20
    """How often a running FollowJointTrajectory goal gets feedback."""


class Ros2Face(msgspec.Struct, frozen=True, forbid_unknown_fields=True):
    """``[ros2]``: the cell runs its ROS 2 face (``services/ros2``, docs/ros2.md): MotoROS2's ROS 2
    API from an rclpy node. The keys are those of MotoROS2's ``motoros2_config.yaml`` that
    apply to a simulated controller, with its defaults; ``open_discovery`` is motocell's own."""

    ros_domain_id: int = 0
    node_name: str = ""
    """Empty: ``motoman_<cell name>`` (MotoROS2 names its node after the controller's MAC)."""
    node_namespace: str = ""
    joint_names: list[list[str]] | None = None
    """Per group, in group order, each group's in the controller's axis order (a 7-axis arm's
    elbow E last, as motoros2_config.yaml lists them); default ``group_<g>/joint_<j>`` from 1."""
    publish_tf: bool = True
    namespace_tf: bool = True
    tf_frame_prefix: str = ""
    update_periods: UpdatePeriods = msgspec.field(default_factory=UpdatePeriods)
    open_discovery: bool = False
    """Let ROS 2 discovery reach beyond this host. Off, the face is seen on this host only
    (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``): any node that sees it can move the robot."""


class CellFile(msgspec.Struct, frozen=True, forbid_unknown_fields=True):
    """The TOML file as written; ``Cell`` is the resolved form the services use."""

    name: str = "cell1"
    controller: ControllerModel = ControllerModel.YRC1000
    byte_order: Literal["little", "big"] | None = None
    interpolation_period_ms: float = 4.0
    state_period_ms: float = 10.0
    max_lateness_periods: int = DEFAULT_MAX_LATENESS_PERIODS
    """How late (in interpolation periods) the executor may apply an increment; a longer stall
    stops motion and raises an alarm (docs/behaviour.md, "Stalls")."""
    pending_points: int = 1
    """How many accepted points a group may hold waiting for its interpolator: 1 is MotoROS's
    single pending point (motoros1 §3.1); more is motocell's deeper pending-point FIFO
    (docs/behaviour.md, "Pending points")."""
    start_buffer_periods: int = DEFAULT_START_BUFFER_PERIODS
    """How many periods a trajectory from rest waits in the ring before it moves: motocell's
    start buffer, a margin against late points for clients that stream without lookahead; 0 is
    MotoROS's timing (the first increment goes out at the next tick) (docs/behaviour.md,
    "Start buffer")."""
    host: str = "127.0.0.1"
    port_base: int = 50240
    groups: list[GroupConfig] = msgspec.field(default_factory=lambda: [GroupConfig()])
    zenoh: ZenohConfig = msgspec.field(default_factory=ZenohConfig)
    models: dict[str, RobotModel] = msgspec.field(default_factory=dict)
    """Extra robot models for this cell, added to (or replacing) the catalogue's."""
    tools: list[list[float]] = msgspec.field(default_factory=list)
    """The controller's tool files from tool 0 on: [x, y, z, rx, ry, rz] each, the tool centre
    point in the flange frame (metres; roll-pitch-yaw in radians, ``forward_kinematics``).
    Tools not listed are all zero: the TCP is the flange."""
    ros2: Ros2Face | None = None
    """The ROS 2 face; a cell file without ``[ros2]`` runs none."""


@dataclass(frozen=True)
class Group:
    index: int
    name: str
    model_name: str
    model: RobotModel
    initial_position: tuple[float, ...]
    joint_limits: tuple[tuple[float, float], ...]
    """[lower, upper] per axis in ROS order: the model's, or the cell file's narrower ones."""
    base: Placement = dataclasses.field(default_factory=Placement)
    """Where the group stands in the cell (``GroupConfig.base``)."""
    own_servo: ServoSettings | None = None
    """The cell file's servo for this group (``GroupConfig.servo``), if it names one."""

    @property
    def axes(self) -> int:
        return self.model.axes

    @property
    def servo(self) -> ServoSettings:
        """The group's servo: the cell file's, else the model's."""
        return self.model.servo if self.own_servo is None else self.own_servo


@dataclass(frozen=True)
class Cell:
    name: str
    controller: ControllerModel
    byte_order: Literal["little", "big"]
    period_ns: int
    state_period_ns: int
    host: str
    port_base: int
    groups: tuple[Group, ...]
    zenoh: ZenohConfig
    max_lateness_periods: int = DEFAULT_MAX_LATENESS_PERIODS
    pending_points: int = 1
    """The pending-point FIFO's depth per group (``CellFile.pending_points``)."""
    start_buffer_periods: int = DEFAULT_START_BUFFER_PERIODS
    """Hold entries before a trajectory's first segment (``CellFile.start_buffer_periods``)."""
    tools: tuple[tuple[float, ...], ...] = ()
    """The tool files MOTO_SELECT_TOOL chooses from (``CellFile.tools``); one table for every
    group, as a controller has."""
    ros2: Ros2Face | None = None
    """The ROS 2 face's settings, its defaults filled in (``CellFile.ros2``); None: no face."""

    def tool(self, number: int) -> tuple[float, ...]:
        """Tool ``number``'s [x, y, z, rx, ry, rz]; an unlisted tool is all zero. A number a
        controller has no tool for (outside 0-63) raises ValueError: MOTO_SELECT_TOOL refuses
        it before it gets here, and a negative one must not pick a tool from the end."""
        if number not in TOOL_NUMBERS:
            raise ValueError(f"tool {number}: a controller has tools 0 to {TOOL_NUMBERS[-1]}")
        return self.tools[number] if number < len(self.tools) else (0.0,) * 6

    @property
    def points_outstanding(self) -> int:
        """The most points a group may have published and not yet taken by its interpolator:
        the pending-point FIFO, or the gateway's look-ahead when that allows more."""
        return max(self.pending_points, LOOK_AHEAD_POINTS)

    @property
    def period_s(self) -> float:
        return self.period_ns / 1e9

    @property
    def motion_port(self) -> int:
        """The ports follow MotoROS's layout (50240 motion, 50241 state, 50242 I/O): the one
        place that knows it."""
        return self.port_base

    @property
    def state_port(self) -> int:
        return self.port_base + 1

    @property
    def io_port(self) -> int:
        return self.port_base + PORT_COUNT - 1

    def listening_at(
        self,
        host: str | None,
        port_base: int | None,
        byte_order: Literal["little", "big"] | None = None,
    ) -> Cell:
        """This cell served elsewhere (a service's ``--host``, ``--port-base`` and
        ``--byte-order``); None keeps the cell file's."""
        return dataclasses.replace(
            self,
            host=host or self.host,
            port_base=port_base or self.port_base,
            byte_order=byte_order or self.byte_order,
        )


@functools.cache
def load_catalogue() -> types.MappingProxyType[str, RobotModel]:
    """The robot models motocell ships (``models.toml``), read once per process: a fact of the
    installation. Read-only, as every caller gets the same one."""
    text = (SHARED / "models.toml").read_text()
    return types.MappingProxyType(
        _decode_models(tomllib.loads(text).get("models", {}), "models.toml")
    )


def _decode_models(raw: object, where: str) -> dict[str, RobotModel]:
    if not isinstance(raw, dict):
        raise ConfigError(f"{where}: models: must be a table of [models.<name>] tables")
    models = {}
    for name, fields in raw.items():
        try:
            models[name] = msgspec.convert(fields, RobotModel)
        except msgspec.ValidationError as exc:
            raise ConfigError(f"{where}: {_problem(exc, f'models.{name}', RobotModel)}") from exc
        _check_model(f"{where}: models.{name}", models[name])
    return models


def _problem(
    exc: msgspec.ValidationError, prefix: str = "", within: type[msgspec.Struct] | None = None
) -> str:
    """msgspec says "Expected `int`, got `str` - at `$.groups[0].name`"; we say
    "groups[0].name: Expected `int`, got `str`", naming the field first. A misspelt field
    gets the nearest one of the table it is in (``within``: the whole file's, ``CellFile``)."""
    problem, _, at = str(exc).partition(" - at `")
    path = at.rstrip("`").removeprefix("$").removeprefix(".")
    problem += _did_you_mean(problem, path, within or CellFile)
    problem += _choices(problem, path, within or CellFile)
    if prefix and path:
        path = prefix + ("" if path.startswith("[") else ".") + path
    field = path or prefix
    return f"{field}: {problem}" if field else problem


def _field_type(path: str, within: type[msgspec.Struct]) -> Any:
    """The declared type at ``path`` ("groups[0].servo") of ``within``."""
    table: Any = within
    for step in re.findall(r"\w+", path):  # "groups[0]": the field, then a list item
        if step.isdigit():
            (table,) = typing.get_args(table)
        else:
            table = {field.name: field.type for field in msgspec.structs.fields(table)}[step]
    return table


def _choices(problem: str, path: str, within: type[msgspec.Struct]) -> str:
    """For a value its field does not take, of a field with a fixed set (an enum, a Literal,
    either or None): the set."""
    if not problem.startswith("Invalid enum value"):
        return ""
    kind = _field_type(path, within)
    values: list[object] = []
    either = typing.get_origin(kind) in (typing.Union, types.UnionType)
    for member in typing.get_args(kind) if either else (kind,):
        if isinstance(member, type) and issubclass(member, Enum):
            values += [choice.value for choice in member]
        elif typing.get_origin(member) is Literal:
            values += typing.get_args(member)
    return "; one of: " + ", ".join(map(str, values)) if values else ""


def _did_you_mean(problem: str, path: str, within: type[msgspec.Struct]) -> str:
    unknown = re.fullmatch(r"Object contains unknown field `(.+)`", problem)
    if unknown is None:
        return ""
    table = _field_type(path, within)
    # A union (``servo``) offers the fields of each of its tables but the one that failed.
    tables = [t for t in typing.get_args(table) or (table,) if isinstance(t, type)]
    names = [
        field.name
        for t in tables
        if issubclass(t, msgspec.Struct)
        for field in msgspec.structs.fields(t)
        if field.name != unknown[1]
    ]
    # Only a refused file needs difflib: imported at the top, 1 ms of every process's start.
    import difflib  # noqa: PLC0415

    close = difflib.get_close_matches(unknown[1], names, n=1)
    return f"; did you mean `{close[0]}`?" if close else ""


def _check_model(where: str, model: RobotModel) -> None:
    n = model.axes
    if not 1 <= n <= MAX_AXES:
        raise ConfigError(f"{where}.axis_types: {n} axes, a group has 1 to {MAX_AXES}")
    if model.seven_axis and n != 7:
        raise ConfigError(f"{where}.seven_axis: set, but the model has {n} axes, not 7")
    for field in ("pulses_per_unit", "max_speed", "max_accel", "initial_position"):
        values: list[float] = getattr(model, field)
        if len(values) != n:
            raise ConfigError(f"{where}.{field}: {len(values)} values for {n} axes")
        if not all(math.isfinite(v) for v in values):
            raise ConfigError(f"{where}.{field}: values must be finite numbers")
    for field in ("pulses_per_unit", "max_speed"):
        if any(v <= 0 for v in getattr(model, field)):
            raise ConfigError(f"{where}.{field}: values must be > 0")
    if len(model.dh) > n or any(len(link) != 4 for link in model.dh):
        raise ConfigError(f"{where}.dh: at most {n} links of [theta, d, a, alpha]")
    _check_limits(f"{where}.joint_limits", model.joint_limits, n)
    _check_within(f"{where}.initial_position", model.initial_position, model.joint_limits)
    _check_servo(f"{where}.servo", model.servo)


def _check_servo(where: str, servo: ServoSettings) -> None:
    if not isinstance(servo, PositionLoop):
        return
    if not (math.isfinite(servo.gain) and servo.gain > 0):
        raise ConfigError(f"{where}.gain: {servo.gain} must be a number above 0 (1/s)")
    if not 0 <= servo.feed_forward <= 1:
        raise ConfigError(f"{where}.feed_forward: {servo.feed_forward} must be 0 to 1")
    if not (math.isfinite(servo.filter_ms) and servo.filter_ms >= 0):
        raise ConfigError(f"{where}.filter_ms: {servo.filter_ms} must be a number from 0 (ms)")


def _check_limits(where: str, limits: list[list[float]], axes: int) -> None:
    """``axes`` pairs of finite numbers, each lower <= upper."""
    if len(limits) != axes or any(len(pair) != 2 for pair in limits):
        raise ConfigError(f"{where}: needs {axes} [lower, upper] pairs, got {limits}")
    for axis, (lower, upper) in enumerate(limits):
        if not (math.isfinite(lower) and math.isfinite(upper) and lower <= upper):
            raise ConfigError(f"{where}[{axis}]: [{lower}, {upper}] is not a finite range")


def _check_within(where: str, position: Sequence[float], limits: Sequence[Sequence[float]]) -> None:
    for axis, (value, (lower, upper)) in enumerate(zip(position, limits, strict=True)):
        if not lower <= value <= upper:
            raise ConfigError(f"{where}[{axis}]: {value} is outside the range [{lower}, {upper}]")


def _check_tools(where: str, tools: list[list[float]]) -> None:
    if len(tools) > len(TOOL_NUMBERS):
        raise ConfigError(f"{where}: {len(tools)} tools, a controller has {len(TOOL_NUMBERS)}")
    for number, tool in enumerate(tools):
        if len(tool) != 6 or not all(math.isfinite(v) for v in tool):
            raise ConfigError(f"{where}[{number}]: needs 6 finite values [x, y, z, rx, ry, rz]")


def _check_placement(where: str, placement: Placement) -> None:
    for name, values in (("xyz", placement.xyz), ("rpy", placement.rpy)):
        if len(values) != 3 or not all(math.isfinite(v) for v in values):
            raise ConfigError(f"{where}.{name}: needs 3 finite values, got {values}")


def _group_limits(
    field: str, group: GroupConfig, model: RobotModel
) -> tuple[tuple[float, float], ...]:
    """The group's joint ranges: the model's, narrowed by the cell file; widening is refused,
    since the model's range is the mechanism's (a real controller's parameters are the same)."""
    if group.joint_limits is None:
        return model.ranges
    where = f"{field}.joint_limits"
    _check_limits(where, group.joint_limits, model.axes)
    for axis, (pair, allowed) in enumerate(
        zip(group.joint_limits, model.joint_limits, strict=True)
    ):
        if pair[0] < allowed[0] or pair[1] > allowed[1]:
            raise ConfigError(
                f"{where}[{axis}]: {pair} widens the model's range {allowed}; "
                "a cell file can only narrow it"
            )
    return tuple((lower, upper) for lower, upper in group.joint_limits)


def load_cell(path: str | Path | None = None, name: str | None = None) -> Cell:
    """Read and resolve a cell file; ``None`` gives the default one-arm YRC1000 cell.
    ``name`` overrides the file's (``motocell up --name``)."""
    cell = _load_cell(path)
    if name is None:
        return cell
    _check_name(name, "--name")
    return dataclasses.replace(cell, name=name)


def _check_name(name: str, where: str) -> None:
    if not name or not all(c.isalnum() or c in "-_" for c in name):
        raise ConfigError(f"{where}: name: {name!r} must be letters, digits, - or _")


def sample_cells() -> list[str]:
    """The sample cell files installed with motocell (``shared/cells``), by name."""
    return sorted(entry.stem for entry in SAMPLE_CELLS.glob("*.toml"))


def _cell_text(path: str | Path) -> str:
    """A file's text; a bare name that is no file (``four-group``) names a sample cell, so the
    samples work from an installed wheel as from the source tree."""
    candidate = Path(path)
    is_name = candidate.name == str(path) and candidate.suffix == ""
    if is_name and not candidate.exists():
        sample = SAMPLE_CELLS / f"{path}.toml"
        if not sample.is_file():
            known = ", ".join(sample_cells())
            raise ConfigError(f"{path}: no such file, nor a sample cell (samples: {known})")
        return sample.read_text()
    try:
        return read_text_bounded(candidate, CELL_FILE_LIMIT)
    except FileRefusedError as exc:
        raise ConfigError(f"cell file {exc}") from None
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read: {exc.strerror}") from exc


def _load_cell(path: str | Path | None) -> Cell:
    if path is None:
        return resolve(CellFile())
    return parse_cell(read_cell_table(path), str(path))


def read_cell_table(path: str | Path) -> dict[str, Any]:
    """A cell file's tables as written, not yet checked (``parse_cell`` checks them): a file,
    or a sample cell's name."""
    try:
        return tomllib.loads(_cell_text(path))
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML: {exc}") from exc


def parse_cell(raw: dict[str, Any], where: str = "cell") -> Cell:
    fields = dict(raw)
    extra_models = _decode_models(fields.pop("models"), where) if "models" in fields else {}
    try:
        cell_file = msgspec.convert(fields, CellFile)
    except msgspec.ValidationError as exc:
        raise ConfigError(f"{where}: {_problem(exc)}") from exc
    return resolve(cell_file, extra_models, where)


def _resolve_group(
    index: int, group: GroupConfig, models: dict[str, RobotModel], field: str
) -> Group:
    model = models.get(group.model)
    if model is None:
        known = ", ".join(sorted(models))
        raise ConfigError(f"{field}.model: unknown model {group.model!r} (known: {known})")
    initial = model.initial_position if group.initial_position is None else group.initial_position
    if len(initial) != model.axes or not all(math.isfinite(v) for v in initial):
        raise ConfigError(
            f"{field}.initial_position: needs {model.axes} finite values, got {initial}"
        )
    limits = _group_limits(field, group, model)
    _check_within(f"{field}.initial_position", initial, limits)
    _check_placement(f"{field}.base", group.base)
    if group.servo is not None:
        _check_servo(f"{field}.servo", group.servo)
    return Group(
        *(index, group.name, group.model, model, tuple(initial), limits, group.base),
        own_servo=group.servo,
    )


def resolve(
    cell_file: CellFile, extra_models: dict[str, RobotModel] | None = None, where: str = "cell"
) -> Cell:
    models = {**load_catalogue(), **(extra_models or {})}
    profile = PROFILES[cell_file.controller]
    _check_name(cell_file.name, where)
    if not 1 <= len(cell_file.groups) <= profile.max_groups:
        raise ConfigError(
            f"{where}: groups: {len(cell_file.groups)} groups, a {cell_file.controller} "
            f"has 1 to {profile.max_groups}"
        )
    if not math.isfinite(cell_file.interpolation_period_ms) or not math.isfinite(
        cell_file.state_period_ms
    ):
        raise ConfigError(f"{where}: interpolation_period_ms and state_period_ms must be finite")
    period_ns = round(cell_file.interpolation_period_ms * 1e6)
    if not 500_000 <= period_ns <= 100_000_000:
        raise ConfigError(f"{where}: interpolation_period_ms: must be 0.5 to 100")
    state_period_ns = round(cell_file.state_period_ms * 1e6)
    if not period_ns <= state_period_ns <= 1_000_000_000:
        raise ConfigError(
            f"{where}: state_period_ms: must be from one interpolation period to 1000"
        )
    if not 1 <= cell_file.max_lateness_periods <= 1000:
        raise ConfigError(f"{where}: max_lateness_periods: must be 1 to 1000")
    if not 1 <= cell_file.pending_points <= MAX_PENDING_POINTS:
        raise ConfigError(f"{where}: pending_points: must be 1 to {MAX_PENDING_POINTS}")
    if not 0 <= cell_file.start_buffer_periods <= MAX_START_BUFFER_PERIODS:
        raise ConfigError(f"{where}: start_buffer_periods: must be 0 to {MAX_START_BUFFER_PERIODS}")
    if not 1 <= cell_file.port_base <= MAX_PORT_BASE:
        raise ConfigError(f"{where}: port_base: must be 1 to {MAX_PORT_BASE}")
    _check_tools(f"{where}: tools", cell_file.tools)
    groups: list[Group] = []
    for index, group in enumerate(cell_file.groups):
        field = f"{where}: groups[{index}]"
        if any(group.name == other.name for other in groups):
            raise ConfigError(f"{field}.name: {group.name!r} is used twice")
        groups.append(_resolve_group(index, group, models, field))
    return Cell(
        name=cell_file.name,
        controller=cell_file.controller,
        byte_order=cell_file.byte_order or profile.byte_order,
        period_ns=period_ns,
        state_period_ns=state_period_ns,
        host=cell_file.host,
        port_base=cell_file.port_base,
        groups=tuple(groups),
        zenoh=cell_file.zenoh,
        max_lateness_periods=cell_file.max_lateness_periods,
        pending_points=cell_file.pending_points,
        start_buffer_periods=cell_file.start_buffer_periods,
        tools=tuple(tuple(tool) for tool in cell_file.tools),
        ros2=None
        if cell_file.ros2 is None
        else _resolve_ros2(cell_file.ros2, cell_file.name, groups, where),
    )


ROS_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
"""A ROS 2 name's token (node names, each part of a namespace or joint name)."""
ROS_DOMAIN_IDS = range(233)
"""What a ROS 2 domain id may be on Linux (0-101 and 215-232 leave DDS's ports clear of the
kernel's ephemeral range; ROS 2 itself accepts up to 232)."""


def _resolve_ros2(face: Ros2Face, cell_name: str, groups: Sequence[Group], where: str) -> Ros2Face:
    """``[ros2]`` checked, with the node name and joint names filled in."""
    field = f"{where}: ros2"
    if face.ros_domain_id not in ROS_DOMAIN_IDS:
        raise ConfigError(f"{field}.ros_domain_id: must be 0 to {ROS_DOMAIN_IDS[-1]}")
    node_name = face.node_name or "motoman_" + re.sub(r"[^A-Za-z0-9_]", "_", cell_name)
    if not ROS_NAME.fullmatch(node_name):
        raise ConfigError(f"{field}.node_name: {node_name!r} is no ROS 2 node name")
    if not all(
        ROS_NAME.fullmatch(part) for part in face.node_namespace.strip("/").split("/") if part
    ):
        raise ConfigError(f"{field}.node_namespace: {face.node_namespace!r} is no ROS 2 namespace")
    joint_names = face.joint_names or [
        [f"group_{group.index + 1}/joint_{axis + 1}" for axis in range(group.axes)]
        for group in groups
    ]
    _check_joint_names(f"{field}.joint_names", joint_names, groups)
    for group in groups:
        if not ROS_NAME.fullmatch(group.name.lower()):
            raise ConfigError(
                f"{where}: groups[{group.index}].name: {group.name!r} cannot name the face's "
                f"ctrl_groups/<name>/joint_states topic (letters, digits, _)"
            )
    periods = face.update_periods
    for name in ("controller_status_monitor_period", "action_feedback_publisher_period"):
        if not 1 <= getattr(periods, name) <= 1000:
            raise ConfigError(f"{field}.update_periods.{name}: must be 1 to 1000 (ms)")
    return msgspec.structs.replace(face, node_name=node_name, joint_names=joint_names)


def _check_joint_names(field: str, names: list[list[str]], groups: Sequence[Group]) -> None:
    if [len(row) for row in names] != [group.axes for group in groups]:
        raise ConfigError(
            f"{field}: one list per group with a name per axis "
            f"({[group.axes for group in groups]} names), got {[len(row) for row in names]}"
        )
    flat = [name for row in names for name in row]
    bad = [name for name in flat if not all(ROS_NAME.fullmatch(part) for part in name.split("/"))]
    if bad:
        raise ConfigError(f"{field}: {bad[0]!r} is no ROS 2 joint name")
    if len(set(flat)) != len(flat):
        raise ConfigError(f"{field}: every joint needs a name of its own")
