"""A recording's MCAP file: written while recording (``McapSink``), read back (``read_recording``).

Why MCAP: it is the robotics world's standard log container (ROS 2's default bag format), so a
recording opens as-is in Foxglove, the ``mcap`` CLI (info, cat, doctor) and the ``mcap`` readers of
several languages. It is self-describing (each channel names its encoding and carries its schema),
indexed (a summary lets readers seek by time or topic) and append-only while recording.

Layout: one channel per key expression (topic = the key). Payloads the catalogue knows are written
as JSON with field names (``to_named``), with one JSON Schema per payload type; anything else (an
unknown key, or a payload that does not decode) keeps its raw msgpack bytes with a schema that
says none (MCAP's empty schema encoding, allowed for self-describing encodings), so nothing is
lost. Beside them, the topics ``motocell view`` serves (``tools.view_channels``: joints, status,
executor, the 3D scene), so a recording opened in Foxglove shows the view's panels. ``log_time``
and ``publish_time`` are the receive time in ns since the Unix epoch.

The file is written by ``foxglove-sdk``, the library ``motocell view`` serves with, and read back
with ``mcap``; both are in the ``tools`` extra: only the commands that record, view or plot import
this module.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import foxglove
import msgspec
from foxglove.mcap import MCAPWriteOptions
from mcap.reader import make_reader
from mcap.well_known import MessageEncoding

from motocell.shared.bus import catalog
from motocell.shared.bus.keys import ROOT
from motocell.shared.config import Cell
from motocell.tools.view_channels import ViewChannels, json_channel

RAW = foxglove.Schema(name="msgpack", encoding="", data=b"")
"""No schema: MCAP's empty schema encoding, for a self-describing message encoding."""


class WatchedStream:
    """The file as ``foxglove-sdk`` writes it, remembering the first error: the SDK logs a
    failed write (a full disk) instead of raising it, so the recorder asks here after each."""

    def __init__(self, stream: IO[bytes]) -> None:
        self.stream = stream
        self.error: OSError | None = None

    def write(self, data: bytes | bytearray) -> int:
        try:
            return self.stream.write(data)
        except OSError as exc:
            self.error = self.error or exc
            raise

    def seek(self, offset: int, whence: int = 0) -> int:
        return self.stream.seek(offset, whence)

    def flush(self) -> None:
        try:
            self.stream.flush()
        except OSError as exc:
            self.error = self.error or exc
            raise


@dataclass
class _Channel:
    channel: foxglove.Channel
    topic: str
    count: int = 0

    @property
    def id(self) -> int:
        return self.channel.id()


class McapSink:
    """Owns the MCAP file; used by one thread only (the writer thread)."""

    def __init__(
        self,
        stream: IO[bytes],
        on_new_channel: Callable[[str, str, str], None] | None = None,
        cells: Mapping[str, Cell] | None = None,
    ) -> None:
        """``cells``: the cell files known, by name, for the 3D scene of each."""
        self.stream = WatchedStream(stream)
        self.context = foxglove.Context()
        # No compression threads: the cell being recorded may run on these cores.
        options = MCAPWriteOptions(compression_threads=0)
        self.writer = foxglove.open_mcap(self.stream, context=self.context, writer_options=options)
        self.view = ViewChannels(self.context, cells or {})
        self.on_new_channel = on_new_channel
        self.channels: dict[tuple[str, str], _Channel] = {}
        self._last_log_time = 0

    def metadata(self, name: str, data: dict[str, str]) -> None:
        self.writer.write_metadata(name, data)

    def write(self, received_ns: int, key: str, data: bytes) -> None:
        """The sample raw on its key's channel, and on the view's; OSError once the file
        could not be written."""
        try:
            value = catalog.decode(key, data)
        except msgspec.DecodeError:
            value = None  # e.g. a newer, incompatible payload: kept raw below
        # Receive times come from the wall clock, which can step back (NTP); log times never
        # do, so readers replaying in file order see the samples in arrival order.
        log_time = self._last_log_time = max(received_ns, self._last_log_time)
        if value is not None:
            channel = self._channel(key, MessageEncoding.JSON, type(value))
            channel.channel.log(msgspec.json.encode(catalog.to_named(value)), log_time=log_time)
            self.view.publish(key, value, log_time)
        else:
            channel = self._channel(key, MessageEncoding.MessagePack, None)
            channel.channel.log(data, log_time=log_time)
        channel.count += 1
        if self.stream.error is not None:
            raise self.stream.error

    def _channel(
        self, key: str, encoding: str, payload_type: type[msgspec.Struct] | None
    ) -> _Channel:
        channel = self.channels.get((key, encoding))
        if channel is not None:
            return channel
        metadata = {"cell": catalog.cell_of(key)} if key.count("/") >= 1 else {}
        if payload_type is None:
            metadata["payload"] = "msgpack, not in the catalogue or not decodable"
            made = foxglove.Channel(
                key, schema=RAW, message_encoding=encoding, context=self.context, metadata=metadata
            )
        else:
            metadata["payload"] = payload_type.__name__
            made = json_channel(key, payload_type, self.context, metadata)
        channel = _Channel(made, key)
        self.channels[(key, encoding)] = channel
        if self.on_new_channel is not None:
            self.on_new_channel(key, encoding, metadata["payload"])
        return channel

    def finish(self) -> None:
        """The summary and the footer; OSError when they could not be written."""
        try:
            self.writer.close()
        except RuntimeError as exc:  # foxglove-sdk's error, for what the stream raised
            raise self.stream.error or OSError(str(exc)) from exc


# --------------------------------------------------------------------------- reading back


def read_recording(path: str | Path) -> Iterator[tuple[str, int, dict[str, Any]]]:
    """(key, log_time_ns, payload) of every JSON message on a key of the cells, in log-time
    order.

    The view's topics (``/<cell>/...``) and raw msgpack channels (keys the catalogue does not
    know) are left out; read them with ``mcap.reader.make_reader``.
    """
    with open(path, "rb") as stream:
        reader = make_reader(stream)
        for _schema, channel, message in reader.iter_messages(log_time_order=True):
            if channel.message_encoding != MessageEncoding.JSON:
                continue
            if not channel.topic.startswith(f"{ROOT}/"):
                continue
            payload = msgspec.json.decode(message.data, type=dict[str, Any])
            yield channel.topic, message.log_time, payload
