"""A recording's MCAP file: written while recording (``McapSink``), read back (``Recording``).

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
(a cut one repaired) with ``mcap``; both are in the ``tools`` extra: only the commands that
record, view or plot import this module.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Generator, Iterator, Mapping
from contextlib import closing
from pathlib import Path
from typing import IO, Any

import foxglove
import msgspec
from foxglove.mcap import MCAPWriteOptions
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import (
    Attachment,
    Channel,
    DataEnd,
    Header,
    McapRecord,
    Message,
    Metadata,
    Schema,
)
from mcap.stream_reader import StreamReader
from mcap.well_known import MessageEncoding
from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter

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
        self.channels: dict[tuple[str, str], foxglove.Channel] = {}
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
            channel.log(msgspec.json.encode(catalog.to_named(value)), log_time=log_time)
            self.view.publish(key, value, log_time)
        else:
            channel = self._channel(key, MessageEncoding.MessagePack, None)
            channel.log(data, log_time=log_time)
        if self.stream.error is not None:
            raise self.stream.error

    def _channel(
        self, key: str, encoding: str, payload_type: type[msgspec.Struct] | None
    ) -> foxglove.Channel:
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
        self.channels[(key, encoding)] = made
        if self.on_new_channel is not None:
            self.on_new_channel(key, encoding, metadata["payload"])
        return made

    def flush(self) -> None:
        """Close the chunk being filled and hand the file everything written so far, so a
        recorder killed later loses nothing of it; OSError once the file could not be
        written."""
        try:
            self.writer.flush()
        except RuntimeError as exc:  # foxglove-sdk's error, for what the stream raised
            raise self.stream.error or OSError(str(exc)) from exc
        if self.stream.error is not None:
            raise self.stream.error

    def finish(self) -> None:
        """The summary and the footer; OSError when they could not be written."""
        try:
            self.writer.close()
        except RuntimeError as exc:  # foxglove-sdk's error, for what the stream raised
            raise self.stream.error or OSError(str(exc)) from exc


# --------------------------------------------------------------------------- reading back


class Recording:
    """A recording read back, whole or cut: a recorder killed (SIGKILL, a power cut) leaves a
    file without its summary, whose last chunk may end mid-record. The standard MCAP reader
    refuses such a file; this one reads its records in file order and keeps every message
    before the cut (``McapSink`` flushes them at least every ``FLUSH_S``)."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.cut = False
        """Known once ``messages`` has run to its end: the file stops before its footer."""

    def records(self) -> Generator[McapRecord]:
        """Every record before the cut (chunks opened into their records), in file order.
        OSError for a file that cannot be read, NotARecordingError for one that is not MCAP."""
        with open(self.path, "rb") as stream:
            if stream.read(len(MCAP_MAGIC)) != MCAP_MAGIC:
                raise NotARecordingError(
                    f"{self.path}: not an MCAP file (`motocell record` writes them)"
                )
            stream.seek(0)
            self.cut = True
            records = StreamReader(stream).records
            while True:
                try:
                    record = next(records)
                except StopIteration:  # the footer and the closing magic were read
                    self.cut = False
                    return
                except (McapError, struct.error):
                    return  # the cut: a record, or the closing magic, runs past the end
                yield record

    def messages(self) -> Iterator[tuple[str, int, dict[str, Any]]]:
        """(key, log_time_ns, payload) of every JSON message on a key of the cells, in
        log-time order (``McapSink`` writes them in that order). OSError for a file that
        cannot be read, NotARecordingError for one that is not MCAP.

        The view's topics (``/<cell>/...``) and raw msgpack channels (keys the catalogue does
        not know) are left out; read them with ``mcap.reader.make_reader``.
        """
        topics: dict[int, str] = {}
        for record in self.records():
            if isinstance(record, Channel) and _of_the_cells(record):
                topics[record.id] = record.topic
            elif isinstance(record, Message) and record.channel_id in topics:
                payload = msgspec.json.decode(record.data, type=dict[str, Any])
                yield topics[record.channel_id], record.log_time, payload


def repair(cut: Recording, out: IO[bytes]) -> int:
    """Everything ``cut`` holds before its cut, into ``out`` as a whole MCAP file: the same
    header, metadata, attachments, schemas, channels and messages in the same order, and the
    summary a recorder killed outright could not write, which indexed readers (Foxglove,
    ``make_reader``) need. The messages copied; OSError, NotARecordingError as ``records``."""
    writer = McapWriter(out, compression=CompressionType.ZSTD)
    started = False
    schemas: dict[int, int] = {0: 0}
    """A schema's id in ``cut``: its id in ``out`` (0: none, in both)."""
    channels: dict[int, int] = {}
    copied = 0
    with closing(cut.records()) as records:
        for record in records:
            if isinstance(record, Header):
                writer.start(record.profile, record.library)
                started = True
            elif isinstance(record, Schema) and record.id not in schemas:
                schemas[record.id] = writer.register_schema(
                    record.name, record.encoding, record.data
                )
            elif isinstance(record, Channel) and record.id not in channels:
                channels[record.id] = writer.register_channel(
                    record.topic,
                    record.message_encoding,
                    schemas[record.schema_id],
                    record.metadata,
                )
            elif isinstance(record, Message):
                writer.add_message(
                    channels[record.channel_id],
                    record.log_time,
                    record.data,
                    record.publish_time,
                    record.sequence,
                )
                copied += 1
            elif isinstance(record, Metadata):
                writer.add_metadata(record.name, record.metadata)
            elif isinstance(record, Attachment):
                writer.add_attachment(
                    record.create_time, record.log_time, record.name, record.media_type, record.data
                )
            elif isinstance(record, DataEnd):
                break  # a whole file: its summary follows, and the writer makes its own
    if not started:  # cut inside its header
        writer.start()
    writer.finish()  # type: ignore[no-untyped-call]  # mcap leaves it unannotated
    return copied


def channel_counts(path: str | Path) -> list[tuple[str, int]]:
    """(topic, messages) of every channel of a whole recording, from its summary's
    statistics: its keys' channels and the view's."""
    with open(path, "rb") as stream:
        summary = make_reader(stream).get_summary()
    if summary is None or summary.statistics is None:
        return []
    counts = summary.statistics.channel_message_counts
    return [(channel.topic, counts.get(channel.id, 0)) for channel in summary.channels.values()]


class NotARecordingError(ValueError):
    """The file does not start as an MCAP file does."""


MCAP_MAGIC = b"\x89MCAP0\r\n"
"""The first 8 bytes of every MCAP file (the MCAP format specification, "Magic")."""


def _of_the_cells(channel: Channel) -> bool:
    """A key of the cells, in JSON: not one of the view's topics, nor a raw msgpack one."""
    return channel.message_encoding == MessageEncoding.JSON and channel.topic.startswith(f"{ROOT}/")
