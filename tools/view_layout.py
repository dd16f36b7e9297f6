"""A Foxglove layout for ``motocell view`` and recordings, drawn to be read in a 1280x800
window: the 3D scene on the left above each cell's four status lights, and on the right a tab
per group (its joint positions, feedback solid and commanded dashed, above its velocities)
and a tab per cell for the controller (its whole status message, the executor's lateness and
the queue depths).

The file is a layout as Foxglove's "Export..." writes it and "Import from file..." reads it:
``configById`` (each panel's settings, keyed ``<PanelType>!<id>``), ``layout`` (the split tree
of those ids, each split giving its first part ``splitPercentage`` of the space),
``globalVariables``, ``userNodes``, ``playbackConfig``. The panels' settings are built with
``foxglove.layouts``, the schema of each panel's configuration that ``foxglove-sdk`` ships, so
their field names are Foxglove's own; Lichtblick reads the same names (its Plot panel's
``legendDisplay``, ``sidebarDimension`` and ``followingViewWidth`` among them).

``motocell view --layout FILE`` writes one for the cells it views. The default cell's ships in
the package (``SHIPPED``, package data), for an install with no source tree;
``python -m motocell.tools.view_layout`` rewrites it.
"""

from __future__ import annotations

import json
import math
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
PANELS_PX = 696
"""The height the panels get in a 1280x800 window: less Lichtblick's app bar (44 px) and its
playback bar (about 60 px)."""
LIGHTS_ROW_PX = 112
"""A cell's row of status lights: a panel's 30 px toolbar, then the coloured box. Lichtblick
1.28.1 centres an Indicator's label in a box 10vw high (128 px at 1280 px), so in a shorter
panel the label sits about 72 px below the box's top: 80 px of box show it."""
LIGHTS_AT_MOST = 60
"""The share of the left column the lights may take (three cells), the rest the 3D scene's."""
SCENE_SHARE = 55
"""The window's width the 3D scene and the lights take."""
LEGEND_PX = 90
"""A legend beside its plot (``sidebarDimension``): a colour and a short name per series, one
30 px row each, never over the data as Lichtblick's default floating legend is."""
WINDOW_S = 30
"""The time a plot shows, sliding (Foxglove's own choice for live data): without it
Lichtblick's axis spans everything since the connection, and its ticks coarsen."""

Node = str | dict[str, Any]
"""A split tree: a panel id, or a split of two trees."""


def layout(cells: list[Cell]) -> dict[str, Any]:
    """The layout for ``cells``: the first cell's frame is the 3D panel's display frame."""
    panels: dict[str, dict[str, Any]] = {}
    scene = _add(panels, "3D", "scene", _three_d(cells))
    lights = _stack([_lights(panels, cell.name) for cell in cells], "column")
    # Rounded up, to a tenth of a percent: a row is never a fraction of a pixel short.
    lights_share = min(
        LIGHTS_AT_MOST, math.ceil(1000 * LIGHTS_ROW_PX * len(cells) / PANELS_PX) / 10
    )
    tabs = [tab for cell in cells for tab in _cell_tabs(panels, cell)]
    side = _add(panels, "Tab", "cells", {"activeTabIdx": 0, "tabs": tabs})
    return {
        "configById": panels,
        "globalVariables": {},
        "userNodes": {},
        "playbackConfig": {"speed": 1},
        "layout": {
            "first": _split(scene, lights, "column", 100 - lights_share),
            "second": side,
            "direction": "row",
            "splitPercentage": SCENE_SHARE,
        },
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


def _cell_tabs(panels: dict[str, dict[str, Any]], cell: Cell) -> list[dict[str, Any]]:
    """A tab per group, then the cell's controller tab."""
    tabs = []
    for group in cell.groups:
        positions = _add(panels, "Plot", f"{cell.name}{group.name}pos", _positions(cell, group))
        velocities = _add(panels, "Plot", f"{cell.name}{group.name}vel", _velocities(cell, group))
        tabs.append(
            {
                "title": f"{cell.name} {group.name}",
                "layout": _split(positions, velocities, "column", 50),
            }
        )
    tabs.append({"title": f"{cell.name} controller", "layout": _controller(panels, cell)})
    return tabs


def axis_names(group: Group) -> list[str]:
    letters = ARM_AXES.get(group.axes) if group.model.kind == "robot" else None
    return list(letters) if letters else [str(axis + 1) for axis in range(group.axes)]


def _plot(series: list[fl.PlotSeries], unit: str, *, legend: bool) -> fl.PlotConfig:
    return fl.PlotConfig(
        paths=series,
        show_legend=legend,
        legend_display="left" if legend else None,
        sidebar_dimension=LEGEND_PX if legend else None,
        y_axis_label=unit,
        time_window_mode="sliding",
        following_view_width=WINDOW_S,
    )


def _positions(cell: Cell, group: Group) -> dict[str, Any]:
    """Twice as many series as axes, more legend rows than a half-height plot holds: the
    velocities below name the colours, the same per axis."""
    joints = f"/{cell.name}/{group.name}/joints"
    series = []
    for axis, name in enumerate(axis_names(group)):
        colour = COLOURS[axis % len(COLOURS)]
        series.append(_series(f"{joints}.positions[{axis}]", f"{name} feedback", colour, "solid"))
        series.append(
            _series(f"{joints}.command_positions[{axis}]", f"{name} commanded", colour, "dashed")
        )
    # Lichtblick 1.28.1 draws every line solid (seen there): only Foxglove tells the two apart.
    title = f"{cell.name} {group.name} position: feedback, commanded (dashed in Foxglove)"
    return _titled(_plot(series, "rad, m", legend=False), title)


def _velocities(cell: Cell, group: Group) -> dict[str, Any]:
    joints = f"/{cell.name}/{group.name}/joints"
    series = [
        _series(f"{joints}.velocities[{axis}]", name, COLOURS[axis % len(COLOURS)], "solid")
        for axis, name in enumerate(axis_names(group))
    ]
    title = f"{cell.name} {group.name} feedback velocity (each axis's colour)"
    return _titled(_plot(series, "rad/s, m/s", legend=True), title)


def _series(path: str, label: str, colour: str, style: str) -> fl.PlotSeries:
    return fl.PlotSeries(
        value=path,
        label=label,
        color=colour,
        line_style=style,  # type: ignore[arg-type]
        enabled=True,
        timestamp_method="receiveTime",
    )


LIGHTS = (
    ("motion_ready", "motion-ready", True),
    ("servo_on", "servo on", True),
    ("estop", "E-stop", False),
    ("hold", "HOLD", False),
)
"""The status lights: the field, its name, and whether true is the good value."""


def _lights(panels: dict[str, dict[str, Any]], cell: str) -> Node:
    return _stack(
        [_light(panels, cell, field, name, good_when_true=good) for field, name, good in LIGHTS],
        "row",
    )


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
    return _add(panels, "Indicator", f"{cell}{field}", _titled(config, f"{cell} {label}"))


def _controller(panels: dict[str, dict[str, Any]], cell: Cell) -> Node:
    """The whole status message, the executor's lateness and the queue depths."""
    raw = fl.RawMessagesConfig(topic_path=f"/{cell.name}/status", expansion="all")
    status = _add(panels, "RawMessages", f"{cell.name}status", _titled(raw, f"{cell.name} status"))
    executor = f"/{cell.name}/executor"
    # The view sends ticks at its rate, a few of the 250 a second: a late one it did not send
    # still shows in the metrics' worst of each second.
    late = _plot(
        [
            _series(f"{executor}.lateness_us", "tick", COLOURS[3], "solid"),
            _series(f"{executor}/metrics.lateness.max_us", "worst/s", COLOURS[1], "dashed"),
        ],
        "us",
        legend=True,
    )
    depths = _plot(
        [
            _series(f"{executor}.depths[{g.index}]", g.name, COLOURS[g.index], "solid")
            for g in cell.groups
        ],
        "entries",
        legend=True,
    )
    title = f"{cell.name} executor lateness"
    return _stack(
        [
            status,
            _add(panels, "Plot", f"{cell.name}late", _titled(late, title)),
            _add(panels, "Plot", f"{cell.name}depth", _titled(depths, f"{cell.name} queue depths")),
        ],
        "column",
    )


def _split(first: Node, second: Node, direction: str, first_share: float) -> Node:
    return {
        "first": first,
        "second": second,
        "direction": direction,
        "splitPercentage": round(first_share, 2),
    }


def _stack(nodes: Sequence[Node], direction: str) -> Node:
    """``nodes`` side by side in ``direction``, each given the same share."""
    if len(nodes) == 1:
        return nodes[0]
    return _split(nodes[0], _stack(nodes[1:], direction), direction, 100 / len(nodes))


def main() -> None:
    SHIPPED.write_text(layout_text([load_cell(None)]))
    print(f"wrote {SHIPPED}")


if __name__ == "__main__":
    main()
