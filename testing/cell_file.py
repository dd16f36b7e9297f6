"""The cell file a test asks for: a cell file (or the default cell) with some of its top-level
fields set by keyword (``byte_order="big"``, ``pending_points=4``), written out as TOML for the
launcher, which reads only files.

The fields are checked (``shared.config.parse_cell``) before anything starts, so a misspelt
setting fails the test at once with the field named, not as a launcher that exited.
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from motocell.shared.config import ConfigError, parse_cell, read_cell_table

BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


def write_cell_file(
    destination: Path, config: str | Path | None, name: str, settings: Mapping[str, Any]
) -> Path:
    """``config``'s fields (none: the default cell), then ``settings``, then ``name``, checked
    and written to ``destination``. ConfigError names the field that cannot be used."""
    fields = {} if config is None else read_cell_table(config)
    fields = {**fields, **settings, "name": name}
    parse_cell(fields, f"{config or 'the default cell'} with {dict(settings)}")
    destination.write_text("".join(f"{key(k)} = {value(v)}\n" for k, v in fields.items()))
    return destination


def key(name: object) -> str:
    if not isinstance(name, str):
        raise ConfigError(f"{name!r}: a cell file's keys are strings")
    return name if BARE_KEY.fullmatch(name) else string(name)


def value(item: object) -> str:
    """``item`` as a TOML value: tables inline, so every field fits one line."""
    if isinstance(item, bool):
        return "true" if item else "false"
    if isinstance(item, int | float):
        return repr(item)  # 1e-05, inf and nan are TOML as Python writes them
    if isinstance(item, str):
        return string(item)
    if isinstance(item, Mapping):
        return "{" + ", ".join(f"{key(k)} = {value(v)}" for k, v in item.items()) + "}"
    if isinstance(item, Sequence):
        return "[" + ", ".join(value(v) for v in item) + "]"
    raise ConfigError(f"{item!r}: not a value a cell file holds")


def string(text: str) -> str:
    """A TOML basic string: JSON's escapes are TOML's, except that TOML also escapes DEL."""
    return json.dumps(text, ensure_ascii=False).replace("\x7f", "\\u007f")
