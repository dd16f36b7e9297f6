"""The JSON Schemas of the recordings and the view are ones Foxglove reads: its reader takes
"type" boolean, string, number, integer, object and array (of those), and refuses a whole
channel for anything else, "anyOf" and "null" included."""

from __future__ import annotations

from typing import Any

import pytest

from motocell.shared.bus.catalog import PAYLOADS
from motocell.shared.bus.schemas import CommandReply, GroupState
from motocell.tools.json_schema import json_schema
from motocell.tools.view_channels import ExecutorTick

READABLE = {"boolean", "string", "number", "integer", "object", "array"}


def unreadable(schema: dict[str, Any], path: str) -> list[str]:
    """Where ``schema`` (an object's) says something Foxglove's reader refuses."""
    found = []
    for name, field in schema["properties"].items():
        where = f"{path}.{name}"
        kind = field.get("type")
        if kind not in READABLE:
            found.append(f"{where}: {field}")
        elif kind == "object":
            found += unreadable(field, where)
        elif kind == "array":
            items = field["items"]
            if items.get("type") not in READABLE - {"array"}:
                found.append(f"{where}[]: {items}")
            elif items["type"] == "object":
                found += unreadable(items, f"{where}[]")
    return found


NESTED_ARRAYS = {CommandReply}
"""``CommandReply.pulses`` is a list of lists, which Foxglove's JSON Schema reader does not take:
the one payload of a recording (``controller/cmd/incmove_error``) Foxglove cannot open."""


@pytest.mark.parametrize(
    "payload", [*sorted(set(PAYLOADS.values()), key=lambda t: t.__name__), ExecutorTick]
)
def test_every_schema_is_one_foxglove_reads(payload: Any) -> None:
    schema = json_schema(payload)
    assert schema["type"] == "object"
    refused = unreadable(schema, payload.__name__)
    assert refused == (
        [f"{payload.__name__}.pulses[]: {{'type': 'array', 'items': {{'type': 'integer'}}}}"]
        if payload in NESTED_ARRAYS
        else []
    )


def test_an_optional_struct_is_described_as_the_struct() -> None:
    flange = json_schema(GroupState)["properties"]["flange"]
    assert flange["type"] == "object"
    assert set(flange["properties"]) == {"position", "orientation"}
    assert "flange" not in json_schema(GroupState)["required"]
