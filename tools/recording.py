"""A recording's MCAP file: written while recording (``McapSink``), read back (``read_recording``).

Why MCAP: it is the robotics world's standard log container (ROS 2's default bag format), so a
recording opens as-is in Foxglove, the ``mcap`` CLI (info, cat, doctor) and the ``mcap`` readers of
several languages. It is self-describing (each channel names its encoding and carries its schema),
indexed (a summary lets readers seek by time or topic) and append-only while recording.

Layout: one channel per key expression (topic = the key). Payloads the catalogue knows are written
as JSON with field names (``to_named``), with one JSON Schema per payload type; anything else (an
unknown key, or a payload that does not decode) keeps its raw msgpack bytes with no schema, so
nothing is lost. ``log_time`` and ``publish_time`` are the receive time in ns since the Unix epoch.

``mcap`` is in the ``tools`` extra: only the commands that record or plot import this module.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import msgspec
from mcap.reader import make_reader
from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap.writer import Writer

from motocell.shared.bus import catalog

# --------------------------------------------------------------------------- JSON Schema


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
        return {"anyOf": [_schema_of(t) for t in info.types]}
    if isinstance(info, msgspec.inspect.DictType):
        return {"type": "object", "additionalProperties": _schema_of(info.value_type)}
    # Anything else the schemas may grow: accept any value rather than refuse to record.
    return {}


# --------------------------------------------------------------------------- the writer


@dataclass
class _Channel:
    id: int
    topic: str
    count: int = 0
    last_log_time: int = 0


class McapSink:
    """Owns the MCAP file; used by one thread only (the writer thread)."""

    def __init__(
        self, stream: IO[bytes], on_new_channel: Callable[[str, str, str], None] | None = None
    ) -> None:
        self.writer = Writer(stream)
        self.writer.start(profile="", library="motocell record")
        self.on_new_channel = on_new_channel
        self.channels: dict[tuple[str, str], _Channel] = {}
        self.schemas: dict[type[msgspec.Struct], int] = {}

    def metadata(self, name: str, data: dict[str, str]) -> None:
        self.writer.add_metadata(name, data)

    def write(self, received_ns: int, key: str, data: bytes) -> None:
        try:
            value = catalog.decode(key, data)
        except msgspec.DecodeError:
            value = None  # e.g. a newer, incompatible payload: kept raw below
        if value is not None:
            channel = self._channel(key, MessageEncoding.JSON, type(value))
            body = msgspec.json.encode(catalog.to_named(value))
        else:
            channel = self._channel(key, MessageEncoding.MessagePack, None)
            body = data
        # Receive times come from the wall clock, which can step back (NTP); a channel's log
        # times never do, so readers replaying in file order see them in arrival order.
        log_time = max(received_ns, channel.last_log_time)
        channel.last_log_time = log_time
        self.writer.add_message(
            channel.id, log_time=log_time, data=body, publish_time=log_time, sequence=channel.count
        )
        channel.count += 1

    def _channel(
        self, key: str, encoding: str, payload_type: type[msgspec.Struct] | None
    ) -> _Channel:
        channel = self.channels.get((key, encoding))
        if channel is not None:
            return channel
        metadata = {"cell": catalog.cell_of(key)} if key.count("/") >= 1 else {}
        if payload_type is None:
            schema_id = 0
            metadata["payload"] = "msgpack, not in the catalogue or not decodable"
        else:
            schema_id = self._schema(payload_type)
            metadata["payload"] = payload_type.__name__
        channel_id: int = self.writer.register_channel(key, encoding, schema_id, metadata)
        channel = _Channel(channel_id, key)
        self.channels[(key, encoding)] = channel
        if self.on_new_channel is not None:
            self.on_new_channel(key, encoding, metadata["payload"])
        return channel

    def _schema(self, payload_type: type[msgspec.Struct]) -> int:
        schema_id = self.schemas.get(payload_type)
        if schema_id is None:
            data = msgspec.json.encode(json_schema(payload_type))
            schema_id = self.writer.register_schema(
                f"motocell.{payload_type.__name__}", SchemaEncoding.JSONSchema, data
            )
            self.schemas[payload_type] = schema_id
        return schema_id

    def finish(self) -> None:
        # mcap's Writer.finish has no annotations; it writes the summary and the footer.
        self.writer.finish()  # type: ignore[no-untyped-call]


# --------------------------------------------------------------------------- reading back


def read_recording(path: str | Path) -> Iterator[tuple[str, int, dict[str, Any]]]:
    """(key, log_time_ns, payload) of every JSON message of a recording, in log-time order.

    Raw msgpack channels (keys the catalogue does not know) have no named form and are left out;
    read them with ``mcap.reader.make_reader``.
    """
    with open(path, "rb") as stream:
        reader = make_reader(stream)
        for _schema, channel, message in reader.iter_messages(log_time_order=True):
            if channel.message_encoding != MessageEncoding.JSON:
                continue
            payload = msgspec.json.decode(message.data, type=dict[str, Any])
            yield channel.topic, message.log_time, payload
