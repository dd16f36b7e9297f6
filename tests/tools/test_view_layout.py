"""The Foxglove layout: the shipped file is the generator's, every panel is placed and every
placed panel configured, and every path a panel reads is a field the view publishes."""

from __future__ import annotations

import dataclasses
import json
import re
from typing import Any

import msgspec

from motocell.shared.bus.schemas import ControllerStatus, GroupState
from motocell.shared.config import load_cell
from motocell.tools.json_schema import json_schema
from motocell.tools.view_channels import ExecutorTick
from motocell.tools.view_layout import SHIPPED, layout, layout_text

FIELDS: dict[str, type[msgspec.Struct]] = {
    "joints": GroupState,
    "status": ControllerStatus,
    "executor": ExecutorTick,
}
"""The JSON topics a layout reads, by the last part of their name."""


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
    assert [tab["title"] for tab in panels["Tab!cells"]["tabs"]] == ["cell1", "dual"]
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
        parts = topic.strip("/").split("/")
        assert parts[0] == "dual", path
        if len(parts) == 3:
            assert parts[1] in groups and parts[2] == "joints", path
        schema = json_schema(FIELDS[parts[-1]])
        if field:
            name, index = re.fullmatch(r"(\w+)(?:\[(\d+)\])?", field).groups()  # type: ignore[union-attr]
            assert name in schema["properties"], path
            if index is not None and parts[-1] == "joints":
                assert int(index) < groups[parts[1]].axes, path


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
    assert json.loads(text)["layout"]["first"] == "3D!scene"
