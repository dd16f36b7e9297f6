"""A Foxglove layout for ``motocell view`` and recordings: the 3D scene on the left, and per
cell a tab with each group's joint plots (feedback solid, commanded dashed), the controller's
status and the executor's lateness and queue depths.

The file is a layout as Foxglove's "Export..." writes it and "Import from file..." reads it:
``configById`` (each panel's settings, keyed ``<PanelType>!<id>``), ``layout`` (the split tree
of those ids), ``globalVariables``, ``userNodes``, ``playbackConfig``. The panels' settings are
built with ``foxglove.layouts``, the schema of each panel's configuration that ``foxglove-sdk``
ships, so their field names are Foxglove's own.

``motocell view --layout FILE`` writes one for the cells it views. The default cell's ships in
the package (``SHIPPED``, package data), for an install with no source tree;
``python -m motocell.tools.view_layout`` rewrites it.
"""

from __future__ import annotations

import json
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import foxglove.layouts as fl

from motocell.shared.config import Cell, Group, load_cell
from motocell.tools.view_scene import cell_frame

SHIPPED = Path(__file__).resolve().parent / "layouts" / "motocell-layout.json"
"""The default cell's layout, in the installed package too."""
COLOURS = (
    "#1f77b4",
    "#ff7f0e",
    "#2ca02c",
    "#d62728",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#7f7f7f",
)
"""One colour per axis, the same in every plot of a group."""
ARM_AXES = {6: "SLURBT", 7: "SLEURBT"}
"""Motoman's axis letters in ROS order (a 7-axis arm's E sits third)."""
TRUE = "true"
"""How an Indicator panel's rule names a boolean's true value."""

Node = str | dict[str, Any]
"""A split tree: a panel id, or a split of two trees."""


def layout(cells: list[Cell]) -> dict[str, Any]:
    """The layout for ``cells``: the first cell's frame is the 3D panel's display frame."""
    panels: dict[str, dict[str, Any]] = {}
    scene = _add(panels, "3D", "scene", _three_d(cells))
    tabs = [{"title": cell.name, "layout": _cell_tab(panels, cell)} for cell in cells]
    side = _add(panels, "Tab", "cells", {"activeTabIdx": 0, "tabs": tabs})
    return {
        "configById": panels,
        "globalVariables": {},
        "userNodes": {},
        "playbackConfig": {"speed": 1},
        "layout": {"first": scene, "second": side, "direction": "row", "splitPercentage": 55},
    }


def layout_text(cells: list[Cell]) -> str:
    return json.dumps(layout(cells), indent=2) + "\n"


def _add(panels: dict[str, dict[str, Any]], kind: str, name: str, config: Any) -> str:
    """``config`` (a ``foxglove.layouts`` configuration or a dict) under a new panel id: the
    name's letters and digits, numbered when two names keep the same ones (cells ``a-1`` and
    ``a1``), or the second panel would replace the first."""
    readable = f"{kind}!{re.sub(r'[^A-Za-z0-9]', '', name)}"
    panel_id, copies = readable, 1
    while panel_id in panels:
        copies += 1
        panel_id = f"{readable}{copies}"
    panels[panel_id] = json.loads(config.to_json()) if hasattr(config, "to_json") else config
    return panel_id


TITLE_KEYS = ("foxglovePanelTitle", "lichtblickPanelTitle")
"""Where a panel's title is read: Foxglove's key, and Lichtblick's (its fork renamed it; seen
in Lichtblick 1.28.1, whose plots were all titled "Plot" with Foxglove's key alone)."""


def _titled(config: Any, title: str) -> dict[str, Any]:
    named: dict[str, Any] = json.loads(config.to_json())
    return {**dict.fromkeys(TITLE_KEYS, title), **named}


def _three_d(cells: list[Cell]) -> fl.ThreeDeeConfig:
    # The transform topics need no settings: the 3D panel reads every FrameTransforms topic.
    topics: dict[str, fl.BaseRendererTopicSettings] = {
        f"/{cell.name}/scene": fl.BaseRendererSceneUpdateTopicSettings(visible=True)
        for cell in cells
    }
    root = cell_frame(cells[0].name)
    grid = fl.BaseRendererGridLayerSettings(
        visible=True,
        frame_id=root,
        size=6,
        divisions=12,
        label="Floor",
        instance_id="floor",
        order=1,
    )
    return fl.ThreeDeeConfig(
        # The robots first: with a label per frame, about two dozen names in large type
        # covered the arms (seen in Lichtblick 1.28.1). The frames stay; their names are one
        # click away in the panel's settings.
        scene=fl.BaseRendererSceneSettings(transforms=fl.BaseRendererTransforms(show_label=False)),
        follow_tf=root,
        follow_mode="follow-pose",
        camera_state=fl.ThreeDeeCameraState(
            distance=4.5,
            perspective=True,
            phi=60,
            theta_offset=45,
            target=(0, 0, 0),
            target_offset=(0, 0, 0.4),
            target_orientation=(0, 0, 0, 1),
            fovy=45,
            near=0.01,
            far=5000,
        ),
        topics=topics,
        layers={"floor": grid},
    )


def _cell_tab(panels: dict[str, dict[str, Any]], cell: Cell) -> Node:
    rows: list[Node] = []
    for group in cell.groups:
        rows.append(_add(panels, "Plot", f"{cell.name}{group.name}pos", _positions(cell, group)))
        rows.append(_add(panels, "Plot", f"{cell.name}{group.name}vel", _velocities(cell, group)))
    rows.append(_status(panels, cell.name))
    rows.append(_executor(panels, cell))
    return _stack(rows, "column")


def axis_names(group: Group) -> list[str]:
    letters = ARM_AXES.get(group.axes) if group.model.kind == "robot" else None
    return list(letters) if letters else [str(axis + 1) for axis in range(group.axes)]


def _positions(cell: Cell, group: Group) -> dict[str, Any]:
    joints = f"/{cell.name}/{group.name}/joints"
    series = []
    for axis, name in enumerate(axis_names(group)):
        colour = COLOURS[axis % len(COLOURS)]
        series.append(_series(f"{joints}.positions[{axis}]", f"{name} feedback", colour, "solid"))
        series.append(
            _series(f"{joints}.command_positions[{axis}]", f"{name} commanded", colour, "dashed")
        )
    plot = fl.PlotConfig(paths=series, show_legend=True, y_axis_label="position (rad, m)")
    return _titled(plot, f"{cell.name} {group.name}: position, feedback vs commanded")


def _velocities(cell: Cell, group: Group) -> dict[str, Any]:
    joints = f"/{cell.name}/{group.name}/joints"
    series = [
        _series(f"{joints}.velocities[{axis}]", name, COLOURS[axis % len(COLOURS)], "solid")
        for axis, name in enumerate(axis_names(group))
    ]
    plot = fl.PlotConfig(paths=series, show_legend=True, y_axis_label="velocity (rad/s, m/s)")
    return _titled(plot, f"{cell.name} {group.name}: feedback velocity")


def _series(path: str, label: str, colour: str, style: str) -> fl.PlotSeries:
    return fl.PlotSeries(
        value=path,
        label=label,
        color=colour,
        line_style=style,  # type: ignore[arg-type]
        enabled=True,
        timestamp_method="receiveTime",
    )


def _status(panels: dict[str, dict[str, Any]], cell: str) -> Node:
    """Four lights (motion-ready, servo, E-stop, HOLD) above the whole status message."""
    status = f"/{cell}/status"
    lights = [
        _light(panels, cell, "motion_ready", "motion-ready", good_when_true=True),
        _light(panels, cell, "servo_on", "servo on", good_when_true=True),
        _light(panels, cell, "estop", "E-stop", good_when_true=False),
        _light(panels, cell, "hold", "HOLD", good_when_true=False),
    ]
    raw = fl.RawMessagesConfig(topic_path=status, expansion="all")
    everything = _add(panels, "RawMessages", f"{cell}status", _titled(raw, f"{cell} status"))
    return {
        "first": _stack(lights, "row"),
        "second": everything,
        "direction": "column",
        "splitPercentage": 25,
    }


def _light(
    panels: dict[str, dict[str, Any]], cell: str, field: str, label: str, *, good_when_true: bool
) -> str:
    good, bad = "#2ca02c", "#d62728"
    config = fl.IndicatorConfig(
        path=f"/{cell}/status.{field}",
        style="background",
        rules=[
            fl.IndicatorRule(
                raw_value=TRUE,
                operator="=",
                color=good if good_when_true else bad,
                label=f"{label}: YES",
            )
        ],
        fallback_color=bad if good_when_true else good,
        fallback_label=f"{label}: no",
    )
    return _add(panels, "Indicator", f"{cell}{field}", config)


def _executor(panels: dict[str, dict[str, Any]], cell: Cell) -> Node:
    executor = f"/{cell.name}/executor"
    late = fl.PlotConfig(
        paths=[_series(f"{executor}.lateness_us", "tick lateness (us)", COLOURS[3], "solid")],
        show_legend=True,
        y_axis_label="us",
    )
    depths = fl.PlotConfig(
        paths=[
            _series(f"{executor}.depths[{g.index}]", g.name, COLOURS[g.index], "solid")
            for g in cell.groups
        ],
        show_legend=True,
        y_axis_label="entries",
    )
    return {
        "first": _add(panels, "Plot", f"{cell.name}late", _titled(late, "executor lateness")),
        "second": _add(panels, "Plot", f"{cell.name}depth", _titled(depths, "queue depths")),
        "direction": "row",
        "splitPercentage": 50,
    }


def _stack(nodes: Sequence[Node], direction: str) -> Node:
    """``nodes`` side by side in ``direction``, each given the same share."""
    if len(nodes) == 1:
        return nodes[0]
    return {
        "first": nodes[0],
        "second": _stack(nodes[1:], direction),
        "direction": direction,
        "splitPercentage": 100 / len(nodes),
    }


def main() -> None:
    SHIPPED.write_text(layout_text([load_cell(None)]))
    print(f"wrote {SHIPPED}")


if __name__ == "__main__":
    main()
