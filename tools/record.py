"""``motocell record``: every sample of one or more cells, with its receive time, into an MCAP file.

Why MCAP: it is the robotics world's standard log container (ROS 2's default bag format), so a
recording opens as-is in Foxglove, the ``mcap`` CLI (info, cat, doctor) and the ``mcap`` readers of
several languages. It is self-describing (each channel names its encoding and carries its schema),
indexed (a summary lets readers seek by time or topic) and append-only while recording.

Layout: one channel per key expression (topic = the key). Payloads the catalogue knows are written
as JSON with field names (``to_named``), with one JSON Schema per payload type; anything else (an
unknown key, or a payload that does not decode) keeps its raw msgpack bytes with no schema, so
nothing is lost. ``log_time`` and ``publish_time`` are the receive time in ns since the Unix epoch.
"""

from __future__ import annotations

import argparse
import queue
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from types import FrameType
from typing import IO, Any

import msgspec
import zenoh
from mcap.reader import make_reader
from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap.writer import Writer

from shared.bus import catalog
from shared.bus.keys import ROOT
from shared.bus.session import open_session

DEFAULT_ROUTER = "tcp/127.0.0.1:7447"
"""Where ``motocell up`` puts its router."""

QUEUE_SIZE = 100_000
"""Samples waiting for the writer: about 100 s of one busy cell, a few tens of MB at most. A
writer that falls further behind than that loses samples (counted) instead of memory."""

_FORBIDDEN_IN_CELL = set("/*$#?")

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


class Recorder:
    """Zenoh callbacks only stamp and queue a sample; one writer thread writes the file.

    A writing error (a full disk) sets ``stop``: the recording ends and the command fails.
    """

    def __init__(self, sink: McapSink, stop: threading.Event) -> None:
        self.sink = sink
        self.stop = stop
        self.queue: queue.Queue[tuple[int, str, bytes] | None] = queue.Queue(QUEUE_SIZE)
        self.dropped = 0
        self.error: Exception | None = None
        self._thread = threading.Thread(target=self._drain, name="mcap-writer", daemon=True)
        self._thread.start()

    def on_sample(self, sample: zenoh.Sample) -> None:
        """Runs on a Zenoh thread: nothing here may block or write."""
        received_ns = time.time_ns()
        try:
            self.queue.put_nowait((received_ns, str(sample.key_expr), sample.payload.to_bytes()))
        except queue.Full:
            self.dropped += 1

    def _drain(self) -> None:
        while True:
            item = self.queue.get()
            if item is None:  # the stop marker
                return
            if self.error is not None:
                continue  # keep emptying the queue so the stop marker gets through
            try:
                self.sink.write(*item)
            except Exception as exc:  # a full disk, a closed file: report it, stop recording
                self.error = exc
                self.stop.set()

    def close(self) -> None:
        """Write everything queued, then the summary. Call once no callback can run any more."""
        self.queue.put(None)
        self._thread.join()
        if self.error is None:
            try:
                self.sink.finish()
            except OSError as exc:  # the summary did not fit on the disk
                self.error = exc


# --------------------------------------------------------------------------- the command


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("out", metavar="OUT", help="the MCAP file to write (replaced if present)")
    parser.add_argument(
        "--cell",
        action="append",
        default=[],
        metavar="NAME",
        help="record this cell (repeatable; default: every cell on the bus)",
    )
    parser.add_argument(
        "--duration", type=float, metavar="S", help="stop after S seconds (default: at Ctrl-C)"
    )
    parser.add_argument(
        "--zenoh-connect",
        default=DEFAULT_ROUTER,
        metavar="ENDPOINT",
        help=f"the cell's Zenoh router (default {DEFAULT_ROUTER})",
    )


def add_parser(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    record = commands.add_parser(
        "record",
        help="record every sample of running cells into an MCAP file",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_arguments(record)
    record.set_defaults(run=run)


def key_exprs(cells: list[str]) -> list[str]:
    if not cells:
        return [f"{ROOT}/**"]
    for cell in cells:
        if not cell or _FORBIDDEN_IN_CELL & set(cell):
            raise ValueError(f"not a cell name: {cell!r}")
    return [f"{ROOT}/{cell}/**" for cell in dict.fromkeys(cells)]


def run(args: argparse.Namespace) -> int:
    try:
        exprs = key_exprs(args.cell)
    except ValueError as exc:
        print(f"motocell record: {exc}", file=sys.stderr)
        return 2
    if args.duration is not None and not args.duration > 0:
        print("motocell record: --duration must be positive", file=sys.stderr)
        return 2
    try:
        session = open_session("client", [args.zenoh_connect], wait=False)
    except ConnectionError as exc:
        print(
            f"motocell record: no Zenoh router at {args.zenoh_connect} (is the cell up?): {exc}",
            file=sys.stderr,
        )
        return 1
    try:
        return _record(session, exprs, args)
    finally:
        session.close()


def _record(session: zenoh.Session, exprs: list[str], args: argparse.Namespace) -> int:
    try:
        stream = open(args.out, "wb")  # noqa: SIM115 -- closed below, after the summary
    except OSError as exc:
        print(f"motocell record: cannot write {args.out}: {exc}", file=sys.stderr)
        return 1
    started = time.monotonic()
    with stream:

        def announce(key: str, encoding: str, payload: str) -> None:
            # Runs on the writer thread; tells an operator (and tests) what is arriving.
            print(f"+ {key} ({encoding}, {payload})", flush=True)

        sink = McapSink(stream, on_new_channel=announce)
        sink.metadata(
            "motocell.recording",
            {
                "key_exprs": " ".join(exprs),
                "zenoh_connect": args.zenoh_connect,
                "started_unix_ns": str(time.time_ns()),
            },
        )
        stop = threading.Event()
        recorder = Recorder(sink, stop)
        previous = _stop_on_signals(stop)
        try:
            print(f"recording {' '.join(exprs)} into {args.out}; Ctrl-C to stop", flush=True)
            subscribers = [session.declare_subscriber(e, recorder.on_sample) for e in exprs]
            stop.wait(args.duration)
            for subscriber in subscribers:
                subscriber.undeclare()
        finally:
            _restore_signals(previous)
            recorder.close()
    elapsed = time.monotonic() - started
    if recorder.error is not None:
        print(f"motocell record: writing {args.out} failed: {recorder.error}", file=sys.stderr)
        return 1
    _report(args.out, sink, recorder.dropped, elapsed)
    return 0


def _stop_on_signals(stop: threading.Event) -> dict[int, Any]:
    """SIGINT and SIGTERM end the recording normally (the file gets its summary)."""
    if threading.current_thread() is not threading.main_thread():
        return {}  # signal handlers can only be set there; the caller stops by --duration

    def handler(_signum: int, _frame: FrameType | None) -> None:
        stop.set()

    return {sig: signal.signal(sig, handler) for sig in (signal.SIGINT, signal.SIGTERM)}


def _restore_signals(previous: dict[int, Any]) -> None:
    for sig, handler in previous.items():
        signal.signal(sig, handler)


def _report(out: str, sink: McapSink, dropped: int, elapsed: float) -> None:
    channels = sorted(sink.channels.values(), key=lambda c: (c.topic, c.id))
    total = sum(c.count for c in channels)
    print(f"wrote {out}: {total} messages on {len(channels)} channels in {elapsed:.1f} s")
    for channel in channels:
        print(f"{channel.count:>9}  {channel.topic}")
    if dropped:
        print(
            f"motocell record: {dropped} samples dropped (the writer fell behind)",
            file=sys.stderr,
        )


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
