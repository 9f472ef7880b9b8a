"""What an MCAP file holds, and recovering what a torn one still has.

:func:`scan` walks the file record by record, without trusting its summary: every complete,
intact chunk counts (its CRC is checked); the walk stops where the file ends inside a record
(a killed recorder) and skips a chunk whose CRC does not match. :func:`recover` writes what the
walk found into a new, complete file, atomically (it appears whole or not at all).
"""

from __future__ import annotations

import io
import json
import os
import struct
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, Footer, Header, Message, Metadata, Schema
from mcap.stream_reader import breakup_chunk
from mcap.writer import CompressionType, Writer

from facesynth.app.recording.layout import ANNOTATIONS, IMAGE, METADATA_NAME, PROFILE, ROLE_FIELD
from facesynth.app.recording.reader import DAMAGED, MAGIC, RecordingError, check_magic
from facesynth.runtime.atomic import open_atomic

#: Largest record accepted while scanning (a larger length field means a corrupt file).
MAX_RECORD = 1 << 31


@dataclass
class ChannelFigures:
    """Message count and time range of one channel."""

    topic: str
    encoding: str
    schema: str
    count: int = 0
    first_ns: int | None = None
    last_ns: int | None = None
    #: The channel's facesynth role (``layout.ROLES``): a bus message, or a view of one.
    role: str = ""

    @property
    def view(self) -> bool:
        """Whether the channel is a Foxglove view of other messages (frame pixels, landmarks),
        not messages of the bus."""
        return self.role in (IMAGE, ANNOTATIONS)


@dataclass
class Scan:
    """What a walk through a file found."""

    path: Path
    size: int
    profile: str = ""
    library: str = ""
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    channels: dict[int, ChannelFigures] = field(default_factory=dict)
    chunks: int = 0
    damaged_chunks: int = 0
    complete: bool = False
    #: Where the intact data ends (bytes); the rest of a torn file is lost.
    good_bytes: int = 0
    problem: str = ""

    @property
    def messages(self) -> int:
        """Messages found in intact records."""
        return sum(figures.count for figures in self.channels.values())

    @property
    def facesynth(self) -> bool:
        """Whether the file is a facesynth recording."""
        return self.profile == PROFILE


OnRecord = Callable[[object], None]


def _read_record(opcode: int, body: bytes) -> object | None:
    stream = ReadDataStream(io.BytesIO(body))
    kinds = {
        Opcode.HEADER: Header,
        Opcode.SCHEMA: Schema,
        Opcode.CHANNEL: Channel,
        Opcode.CHUNK: Chunk,
        Opcode.METADATA: Metadata,
        Opcode.FOOTER: Footer,
    }
    if opcode == Opcode.MESSAGE:
        return Message.read(stream, len(body))
    kind = kinds.get(opcode)  # type: ignore[call-overload]
    return kind.read(stream) if kind is not None else None


def scan(path: str | Path, on_record: OnRecord | None = None) -> Scan:
    """Walk ``path``; ``on_record`` sees every intact schema, channel, metadata and message."""
    file = Path(path)
    handle = check_magic(file)
    with handle:
        size = os.fstat(handle.fileno()).st_size
        result = Scan(file, size, good_bytes=len(MAGIC))
        schemas: dict[int, str] = {}
        _walk(handle, size, result, schemas, on_record)
    return result


def _walk(
    handle: IO[bytes], size: int, result: Scan, schemas: dict[int, str], on_record: OnRecord | None
) -> None:
    offset = len(MAGIC)
    in_summary = False  # after DataEnd come the summary's copies and indexes: not data
    while True:
        prefix = handle.read(9)
        if len(prefix) < 9:
            result.problem = (
                f"the file ends inside a record at byte {offset}"
                if prefix
                else "the file ends without a footer"
            )
            return
        opcode, length = struct.unpack("<BQ", prefix)
        if length > MAX_RECORD or offset + 9 + length > size:
            result.problem = (
                f"the file ends inside a record at byte {offset} "
                f"(opcode 0x{opcode:02x}, {length} bytes announced)"
            )
            return
        body = handle.read(length)
        if opcode == Opcode.DATA_END:
            in_summary = True
        if in_summary and opcode != Opcode.FOOTER:
            offset += 9 + length
            continue
        try:
            record = _read_record(opcode, body)
        except DAMAGED as exc:
            result.problem = f"an unreadable record at byte {offset}: {exc}"
            return
        offset += 9 + length
        if isinstance(record, Chunk):
            try:
                inner = breakup_chunk(record, validate_crc=True)
            except Exception as exc:  # zstd/lz4/CRC errors have no common base class
                result.damaged_chunks += 1
                result.problem = (
                    f"a damaged chunk at byte {offset - 9 - length} ({exc}) was skipped"
                )
                continue
            result.chunks += 1
            for item in inner:
                _take(item, result, schemas, on_record)
        elif isinstance(record, Footer):
            result.complete = True
            result.good_bytes = offset
            return
        elif record is not None:
            _take(record, result, schemas, on_record)
        result.good_bytes = offset


def _take(
    record: object, result: Scan, schemas: dict[int, str], on_record: OnRecord | None
) -> None:
    if isinstance(record, Header):
        result.profile, result.library = record.profile, record.library
    elif isinstance(record, Schema):
        schemas[record.id] = record.name
    elif isinstance(record, Channel):
        result.channels.setdefault(
            record.id,
            ChannelFigures(
                record.topic,
                record.message_encoding,
                schemas.get(record.schema_id, ""),
                role=record.metadata.get(ROLE_FIELD, ""),
            ),
        )
    elif isinstance(record, Metadata):
        result.metadata[record.name] = dict(record.metadata)
    elif isinstance(record, Message):
        figures = result.channels.get(record.channel_id)
        if figures is None:  # a message before its channel: not a valid file from here
            return
        figures.count += 1
        t = record.log_time
        figures.first_ns = t if figures.first_ns is None else min(figures.first_ns, t)
        figures.last_ns = t if figures.last_ns is None else max(figures.last_ns, t)
    else:
        return
    if on_record is not None:
        on_record(record)


def recover(path: str | Path, out: str | Path) -> Scan:
    """Copy every intact record of ``path`` into a complete file at ``out`` (atomically)."""
    source, target = Path(path), Path(out)
    if source.resolve() == target.resolve():
        raise RecordingError("the recovered copy must not overwrite the file it comes from")
    with open_atomic(target) as stream:
        writer = Writer(stream, compression=CompressionType.ZSTD)
        schema_ids: dict[int, int] = {}
        channel_ids: dict[int, int] = {}
        started = False

        def copy(record: object) -> None:
            nonlocal started
            if isinstance(record, Header):
                writer.start(profile=record.profile, library=record.library)
                started = True
                return
            if not started:
                writer.start()
                started = True
            if isinstance(record, Schema):
                schema_ids[record.id] = writer.register_schema(
                    record.name, record.encoding, record.data
                )
            elif isinstance(record, Channel):
                if record.id not in channel_ids:
                    channel_ids[record.id] = writer.register_channel(
                        record.topic,
                        record.message_encoding,
                        schema_ids.get(record.schema_id, 0),
                        record.metadata,
                    )
            elif isinstance(record, Metadata):
                writer.add_metadata(record.name, record.metadata)
            elif isinstance(record, Message) and record.channel_id in channel_ids:
                writer.add_message(
                    channel_ids[record.channel_id],
                    record.log_time,
                    record.data,
                    record.publish_time,
                    record.sequence,
                )

        result = scan(source, copy)
        if not started:
            writer.start()
        writer.finish()
    return result


def _time(ns: int | None) -> str:
    return "-" if ns is None else f"{ns / 1e9:.3f}"


def describe(result: Scan) -> str:
    """A human-readable account of a scan: state, session, channels with counts and times."""
    state = "complete" if result.complete else "TORN"
    views = sum(f.count for f in result.channels.values() if f.view)
    lines = [
        f"{result.path}: {state}, {result.size} bytes, {result.chunks} chunks, "
        f"{result.messages} MCAP messages: {result.messages - views} from the bus and {views} "
        "Foxglove views of them (frame images, landmark annotations)",
        f"  written by {result.library or '?'} (profile {result.profile or '-'!r})",
    ]
    if not result.facesynth:
        lines.append("  not a facesynth recording: facesynth replay cannot use it")
    session = result.metadata.get(METADATA_NAME)
    if session:
        lines.append("  session: " + json.dumps(session, sort_keys=True))
    if result.problem:
        lines.append(f"  problem: {result.problem}")
    if not result.complete:
        lines.append(
            f"  intact: the first {result.good_bytes} bytes; "
            f"{result.size - result.good_bytes} bytes lost"
        )
    firsts = [f.first_ns for f in result.channels.values() if f.first_ns is not None]
    lasts = [f.last_ns for f in result.channels.values() if f.last_ns is not None]
    if firsts:
        span = (max(lasts) - min(firsts)) / 1e9
        lines.append(
            f"  time: {_time(min(firsts))} .. {_time(max(lasts))} "
            f"(log time, s since epoch; {span:.3f} s)"
        )
    lines.append(
        f"  {'topic':<50} {'messages':>9} {'first s':>16} {'last s':>16}  schema (encoding)"
    )
    for figures in sorted(result.channels.values(), key=lambda f: f.topic):
        lines.append(
            f"  {figures.topic:<50} {figures.count:>9} {_time(figures.first_ns):>16} "
            f"{_time(figures.last_ns):>16}  {figures.schema or '-'} ({figures.encoding})"
        )
    return "\n".join(lines)
