"""The Foxglove layout: the shipped file is the generator's, every panel is placed and every
placed panel configured, every path a panel reads is a field the view publishes, and every
panel is big enough to read in a 1280x800 window."""

from __future__ import annotations

import dataclasses
import json
import re
from typing import Any

import msgspec
import pytest

from motocell.shared.bus.schemas import ControllerStatus, ExecutorMetrics, GroupState
from motocell.shared.config import Cell, load_cell
from motocell.tools.json_schema import json_schema
from motocell.tools.view_channels import ExecutorTick
from motocell.tools.view_layout import SHIPPED, layout, layout_text

FIELDS: dict[str, type[msgspec.Struct]] = {
    "joints": GroupState,
    "status": ControllerStatus,
    "executor": ExecutorTick,
    "executor/metrics": ExecutorMetrics,
}
"""The JSON topics a layout reads, by their name after the cell's (a group's: its last part)."""


def test_the_shipped_layout_is_the_generated_one() -> None:
    assert SHIPPED.read_text() == layout_text([load_cell()]), (
        "run `python -m motocell.tools.view_layout`"
    )


def placed(node: Any, panels: dict[str, Any]) -> set[str]:
    """Every panel id in a split tree, tabs included."""
    if isinstance(node, str):
        found = {node}
        if node.startswith("Tab!"):
            for tab in panels[node]["tabs"]:
                found |= placed(tab["layout"], panels)
        return found
    assert set(node) == {"first", "second", "direction", "splitPercentage"}
    assert node["direction"] in ("row", "column") and 0 < node["splitPercentage"] < 100
    return placed(node["first"], panels) | placed(node["second"], panels)


def test_every_panel_is_placed_and_configured() -> None:
    made = layout([load_cell(), load_cell("dual-arm-positioner")])
    assert set(made) == {"configById", "globalVariables", "userNodes", "playbackConfig", "layout"}
    panels = made["configById"]
    assert placed(made["layout"], panels) == set(panels)
    kinds = {panel.split("!")[0] for panel in panels}
    assert kinds == {"3D", "Plot", "Indicator", "RawMessages", "Tab"}
    assert [tab["title"] for tab in panels["Tab!cells"]["tabs"]] == [
        "cell1 R1",
        "cell1 controller",
        "dual R1",
        "dual R2",
        "dual S1",
        "dual controller",
    ]
    assert set(panels["3D!scene"]["topics"]) == {"/cell1/scene", "/dual/scene"}
    assert panels["3D!scene"]["followTf"] == "cell1"


def test_cells_whose_names_differ_only_in_punctuation_keep_every_panel() -> None:
    cell = load_cell()
    made = layout([dataclasses.replace(cell, name="a-1"), dataclasses.replace(cell, name="a1")])
    panels = made["configById"]
    assert placed(made["layout"], panels) == set(panels)
    one_cell = len(layout([cell])["configById"]) - 2  # less the 3D panel and the tabs
    assert len(panels) == 2 + 2 * one_cell


def paths(config: Any) -> list[str]:
    if isinstance(config, dict):
        found = [config[key] for key in ("value", "path", "topicPath") if key in config]
        return found + [p for value in config.values() for p in paths(value)]
    if isinstance(config, list):
        return [p for value in config for p in paths(value)]
    return []


def test_every_path_names_a_field_the_view_publishes() -> None:
    dual = load_cell("dual-arm-positioner")
    panels = layout([dual])["configById"]
    read = [p for panel in panels.values() for p in paths(panel)]
    assert len(read) > 30
    groups = {g.name: g for g in dual.groups}
    for path in read:
        topic, _, field = path.partition(".")
        cell, _, name = topic.strip("/").partition("/")
        assert cell == "dual", path
        group, _, joints = name.partition("/")
        if joints == "joints":
            assert group in groups, path
            name = joints
        schema = json_schema(FIELDS[name])
        for part in field.split(".") if field else []:
            key, index = re.fullmatch(r"(\w+)(?:\[(\d+)\])?", part).groups()  # type: ignore[union-attr]
            assert key in schema["properties"], path
            if index is not None and name == "joints":
                assert int(index) < groups[group].axes, path
            schema = schema["properties"][key]


def test_every_titled_panel_is_titled_for_foxglove_and_for_lichtblick() -> None:
    panels = json.loads(layout_text([load_cell()]))["configById"]
    titled = [config for config in panels.values() if "foxglovePanelTitle" in config]
    assert titled
    for config in titled:
        assert config["lichtblickPanelTitle"] == config["foxglovePanelTitle"]


def test_the_3d_panel_shows_the_frames_without_their_names() -> None:
    panels = json.loads(layout_text([load_cell()]))["configById"]
    [three_d] = [config for panel, config in panels.items() if panel.startswith("3D")]
    assert three_d["scene"]["transforms"]["showLabel"] is False


def test_the_file_is_json_foxglove_can_import() -> None:
    text = SHIPPED.read_text()
    assert json.loads(text)["layout"]["first"]["first"] == "3D!scene"


WINDOW_PX = (1280, 800)
CHROME_PX = 44 + 60
"""Lichtblick 1.28.1's app bar above the panels (``APP_BAR_HEIGHT``, 44 px) and its playback
bar below them (about 60 px: a scrubber and a row of buttons; not measured). No side bar open,
and the splitters' few pixels not counted."""
TAB_BAR_PX = 30
"""A Tab panel's row of tabs (``PANEL_TOOLBAR_MIN_HEIGHT``)."""
PANEL_TOOLBAR_PX = 30
"""Every panel's own toolbar (its title), inside the panel's size."""
LEGEND_ROW_PX = 30
"""A legend's row per series (Lichtblick's ``PlotLegendRow`` ``ROW_HEIGHT``)."""
SMALLEST_PX = {
    "3D": (400, 300),
    "Plot": (360, 180),
    "Indicator": (150, 112),
    "RawMessages": (300, 180),
}
"""Each kind's smallest readable panel (width, height), toolbar included. A plot: 150 px of
chart under its toolbar hold the time axis's labels and three or four labelled ticks of its
value axis, and 360 px hold a 90 px legend, the value axis's labels and 200 px of data. A
light: 80 px of coloured box show its label (``tools.view_layout.LIGHTS_ROW_PX`` says why). A
status message: a dozen of its lines. The 3D scene: both arms of the dual cell at a size where
the links are told apart."""


def sizes(node: Any, width: float, height: float, panels: dict[str, Any]) -> dict[str, Any]:
    """Each panel's (width, height) in px when ``node`` has ``width`` x ``height``; a Tab
    panel's tabs each get its area less the tab bar."""
    if isinstance(node, str):
        found = {node: (width, height)}
        if node.startswith("Tab!"):
            for tab in panels[node]["tabs"]:
                found |= sizes(tab["layout"], width, height - TAB_BAR_PX, panels)
        return found
    share = node["splitPercentage"] / 100
    if node["direction"] == "row":
        first, second = (width * share, height), (width * (1 - share), height)
    else:
        first, second = (width, height * share), (width, height * (1 - share))
    return sizes(node["first"], *first, panels) | sizes(node["second"], *second, panels)


CELLS = {
    "default": ["default"],
    "dual": ["dual-arm-positioner"],
    "both": ["default", "dual-arm-positioner"],
    "three": ["default", "dual-arm-positioner", "four-group"],
}


def cells(names: list[str]) -> list[Cell]:
    return [load_cell(None if name == "default" else name) for name in names]


@pytest.mark.parametrize("names", CELLS.values(), ids=CELLS.keys())
def test_every_panel_is_readable_in_a_1280x800_window(names: list[str]) -> None:
    made = layout(cells(names))
    panels = made["configById"]
    width, height = WINDOW_PX
    placed_at = sizes(made["layout"], width, height - CHROME_PX, panels)
    small = [
        f"{panel}: {w:.0f}x{h:.0f} px, under {SMALLEST_PX[kind]}"
        for panel, (w, h) in placed_at.items()
        if (kind := panel.split("!")[0]) != "Tab"
        and (w < SMALLEST_PX[kind][0] or h < SMALLEST_PX[kind][1])
    ]
    assert not small, small


@pytest.mark.parametrize("names", CELLS.values(), ids=CELLS.keys())
def test_no_legend_covers_its_plot_and_each_fits_beside_it(names: list[str]) -> None:
    made = layout(cells(names))
    panels = made["configById"]
    placed_at = sizes(made["layout"], WINDOW_PX[0], WINDOW_PX[1] - CHROME_PX, panels)
    plots = {panel: config for panel, config in panels.items() if panel.startswith("Plot!")}
    assert any(config["showLegend"] for config in plots.values())
    for panel, config in plots.items():
        if not config["showLegend"]:
            continue
        assert config["legendDisplay"] == "left", panel  # not "floating", over the data
        chart_height = placed_at[panel][1] - PANEL_TOOLBAR_PX
        assert len(config["paths"]) * LEGEND_ROW_PX <= chart_height, panel
        assert config["followingViewWidth"] > 0, panel
