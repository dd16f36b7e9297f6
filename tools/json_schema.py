"""JSON Schemas of the payloads as ``motocell record`` and ``motocell view`` write them: objects
with field names (``catalog.to_named``), one schema per payload type, so that Foxglove and the
``mcap`` tools show every field by name."""

from __future__ import annotations

from typing import Any

import msgspec


def json_schema(payload_type: type[msgspec.Struct]) -> dict[str, Any]:
    """A JSON Schema (draft 2020-12) of ``payload_type`` in its named-field JSON form.

    ``msgspec.json.schema`` would describe the wire form, arrays (``array_like``); recordings hold
    objects with field names, so the schema is built from the Struct's fields instead. Nested
    Structs are inlined: the schemas are small and some readers do not resolve ``$ref``.
    """
    schema = _schema_of(msgspec.inspect.type_info(payload_type))
    return {"$schema": "https://json-schema.org/draft/2020-12/schema", **schema}


def _schema_of(info: msgspec.inspect.Type) -> dict[str, Any]:
    if isinstance(info, msgspec.inspect.StructType):
        properties = {f.name: _schema_of(f.type) for f in info.fields}
        result: dict[str, Any] = {
            "title": info.cls.__name__,
            "type": "object",
            "properties": properties,
            "required": [f.name for f in info.fields if f.required],
        }
        if info.cls.__doc__:
            result["description"] = " ".join(info.cls.__doc__.split())
        return result
    if isinstance(info, msgspec.inspect.ListType):
        return {"type": "array", "items": _schema_of(info.item_type)}
    if isinstance(info, msgspec.inspect.TupleType):
        items = [_schema_of(t) for t in info.item_types]
        return {"type": "array", "prefixItems": items, "items": False}
    if isinstance(info, msgspec.inspect.BoolType):
        return {"type": "boolean"}
    if isinstance(info, msgspec.inspect.IntType):
        return {"type": "integer"}
    if isinstance(info, msgspec.inspect.FloatType):
        # Plain "number", though msgspec writes a non-finite float as null: viewers such as
        # Foxglove reject a list of types, and no payload carries NaN in practice.
        return {"type": "number"}
    if isinstance(info, msgspec.inspect.StrType):
        return {"type": "string"}
    if isinstance(info, msgspec.inspect.BytesType):
        # msgspec.json encodes bytes (e.g. IncrementBatch.increments) as base64 text.
        return {"type": "string", "contentEncoding": "base64"}
    if isinstance(info, msgspec.inspect.NoneType):
        return {"type": "null"}
    if isinstance(info, msgspec.inspect.UnionType):
        return _union_schema(info)
    if isinstance(info, msgspec.inspect.DictType):
        return {"type": "object", "additionalProperties": _schema_of(info.value_type)}
    # Anything else the schemas may grow: accept any value rather than refuse to record.
    return {}


def _union_schema(info: msgspec.inspect.UnionType) -> dict[str, Any]:
    # Foxglove reads no "anyOf" nor "null" type (its JSON Schema reader refuses the whole
    # channel): an optional field is described as its value, and a null read as absent.
    present = [t for t in info.types if not isinstance(t, msgspec.inspect.NoneType)]
    if len(present) == 1:
        return _schema_of(present[0])
    return {"anyOf": [_schema_of(t) for t in info.types]}
