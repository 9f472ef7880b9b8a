"""Open a facesynth recording and read it back: exact bus payloads, or decoded messages.

A file that is not MCAP, an MCAP file from another tool, and a torn recording (a killed
recorder: no summary at the end) each give one clear :class:`RecordingError`; a torn one names
the command that recovers it.
"""

from __future__ import annotations

import contextlib
import os
import struct
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from mcap.exceptions import McapError
from mcap.reader import SeekingReader
from mcap.records import Channel, Schema
from mcap_protobuf.decoder import DecoderFactory
from zstandard import ZstdError

from facesynth.app.recording.layout import (
    IMAGE,
    KEY_FIELD,
    MESSAGE,
    METADATA_NAME,
    PROFILE,
    RAW,
    ROLE_FIELD,
    Rebuilder,
    RebuildError,
    key_kind,
    key_rig,
    message_type,
)
from facesynth.runtime import codec

MAGIC = b"\x89MCAP0\r\n"
#: What the mcap library raises on a damaged file (found by tests/fuzz): its own errors, a
#: record cut short, bad lengths and strings (ValueError, struct.error, OverflowError), a
#: message on a channel the summary does not have (KeyError), an offset before the start of
#: the file (OSError), chunks that do not decompress (zstd; lz4 raises RuntimeError).
DAMAGED = (
    McapError,
    OSError,
    EOFError,
    ValueError,
    struct.error,
    OverflowError,
    KeyError,
    ZstdError,
    RuntimeError,
)


class RecordingError(ValueError):
    """A file that cannot be read as a facesynth recording; the message says why."""


@dataclass(frozen=True, slots=True)
class Payload:
    """One recorded bus message: its key, exact payload and receipt time (ns since the epoch)."""

    key: str
    payload: bytes
    log_time: int


def check_magic(path: Path) -> IO[bytes]:
    """Open ``path`` for reading if it starts like an MCAP file, else raise RecordingError."""
    try:
        handle = open(path, "rb")  # noqa: SIM115 - returned to the caller
    except OSError as exc:
        raise RecordingError(f"cannot read {path}: {exc.strerror or exc}") from None
    head = handle.read(len(MAGIC))
    if head != MAGIC:
        handle.close()
        what = "an empty file" if not head else f"starts with {head[:8]!r}"
        raise RecordingError(f"{path} is not an MCAP file ({what})")
    return handle


class _BoundedReads:
    """A file whose reads never ask for more than what is left of it: the mcap library reads
    a record's length field and then that many bytes, and a damaged length would make it
    allocate up to 2**64 bytes (MemoryError) before finding the file shorter."""

    def __init__(self, handle: IO[bytes]) -> None:
        self._handle = handle
        self._size = os.fstat(handle.fileno()).st_size

    def read(self, size: int = -1) -> bytes:
        left = max(0, self._size - self._handle.tell())
        return self._handle.read(left if size < 0 or size > left else size)

    def seek(self, offset: int, whence: int = 0) -> int:
        return self._handle.seek(offset, whence)

    def tell(self) -> int:
        return self._handle.tell()

    def seekable(self) -> bool:
        return True


class Recording:
    """A complete facesynth recording, opened for reading (use as a context manager)."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._file = check_magic(self.path)
        try:
            self._open()
        except BaseException:
            self._file.close()
            raise

    def _open(self) -> None:
        path = self.path
        self._file.seek(-len(MAGIC), 2)
        complete = self._file.read(len(MAGIC)) == MAGIC
        self._file.seek(0)
        self._reader = SeekingReader(_BoundedReads(self._file))  # type: ignore[arg-type]
        try:
            header = self._reader.get_header()
        except DAMAGED as exc:
            raise RecordingError(f"{path}: unreadable MCAP header ({exc})") from None
        if header.profile != PROFILE:
            raise RecordingError(
                f"{path} is an MCAP file but not a facesynth recording "
                f"(profile {header.profile!r}, written by {header.library!r})"
            )
        self.library = header.library
        summary = None
        if complete:
            with contextlib.suppress(*DAMAGED):
                summary = self._reader.get_summary()
        if summary is None:
            raise RecordingError(
                f"{path} is torn (no summary: was the recorder killed?); "
                f"recover it with: facesynth record --check {path}"
            )
        self.summary = summary
        self.metadata: dict[str, str] = {}
        with contextlib.suppress(*DAMAGED):
            for record in self._reader.iter_metadata():
                if record.name == METADATA_NAME:
                    self.metadata = dict(record.metadata)
        self.channels: dict[int, Channel] = dict(summary.channels)
        self.schemas: dict[int, Schema] = dict(summary.schemas)
        stats = summary.statistics
        self.counts: dict[int, int] = dict(stats.channel_message_counts) if stats else {}
        self._image_decoders: dict[int, Callable[[bytes], Any]] = {}

    def __enter__(self) -> Recording:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Close the file."""
        self._file.close()

    @property
    def rig(self) -> str:
        """The rig the session was recorded on."""
        if self.metadata.get("rig"):
            return self.metadata["rig"]
        found = self.bus_keys()
        return key_rig(found[0]) if found else "default"

    def _facesynth_channels(self) -> list[Channel]:
        return [
            c
            for c in self.channels.values()
            if c.metadata.get(ROLE_FIELD) and c.metadata.get(KEY_FIELD)
        ]

    def bus_keys(self) -> list[str]:
        """Every bus key with messages in the recording."""
        found = {
            c.metadata[KEY_FIELD]
            for c in self._facesynth_channels()
            if c.metadata[ROLE_FIELD] in (MESSAGE, RAW) and self.counts.get(c.id, 0)
        }
        return sorted(found)

    def count(self, key: str) -> int:
        """How many bus messages the recording holds for ``key``."""
        return sum(
            self.counts.get(c.id, 0)
            for c in self._facesynth_channels()
            if c.metadata[KEY_FIELD] == key and c.metadata[ROLE_FIELD] in (MESSAGE, RAW)
        )

    def stages(self) -> list[str]:
        """The stages (``input`` … ``servo_state``) with messages in the recording (a robot's
        commands or state count as their stage's)."""
        kinds = {key_kind(key) for key in self.bus_keys()}
        return [
            stage
            for stage in ("input", "points", "features", "servo_commands", "servo_state")
            if stage in kinds
        ]

    def stage_keys(self, stage: str) -> list[str]:
        """The bus keys of ``stage`` with messages: the rig's own and, for the per-robot
        stages, each robot's (``…/servo_commands/<robot>``)."""
        return [key for key in self.bus_keys() if key_kind(key) == stage]

    def _topics(self, keys: Iterable[str]) -> list[str]:
        wanted = set(keys)
        return [
            c.topic
            for c in self._facesynth_channels()
            if c.metadata[KEY_FIELD] in wanted and c.metadata[ROLE_FIELD] in (MESSAGE, IMAGE, RAW)
        ]

    def _pixels(self, schema: Schema | None, channel: Channel, data: bytes) -> bytes:
        decode = self._image_decoders.get(channel.id)
        if decode is None:
            try:
                found = DecoderFactory().decoder_for(channel.message_encoding, schema)
            except Exception as exc:  # a damaged schema: protobuf raises its own DecodeError
                raise RecordingError(
                    f"{self.path}: a bad schema on {channel.topic}: {exc}"
                ) from None
            if found is None:
                raise RecordingError(f"{self.path}: cannot decode images on {channel.topic}")
            decode = self._image_decoders[channel.id] = found
        try:
            return bytes(decode(data).data)
        except Exception as exc:  # protobuf raises its own DecodeError
            raise RecordingError(f"{self.path}: a bad image on {channel.topic}: {exc}") from None

    def payloads(self, keys: Iterable[str]) -> Iterator[Payload]:
        """The exact bus payloads recorded on ``keys``, in receipt order."""
        rebuilder = Rebuilder()
        topics = self._topics(keys)
        if not topics:
            return
        try:
            for schema, channel, message in self._reader.iter_messages(
                topics=topics, log_time_order=True
            ):
                key = channel.metadata[KEY_FIELD]
                role = channel.metadata[ROLE_FIELD]
                data = (
                    self._pixels(schema, channel, message.data) if role == IMAGE else message.data
                )
                try:
                    payload = rebuilder.feed(key, role, data, message.sequence)
                except RebuildError as exc:
                    raise RecordingError(f"{self.path}: {exc}") from None
                if payload is not None:
                    yield Payload(key, payload, message.log_time)
        except DAMAGED as exc:
            raise RecordingError(f"{self.path}: damaged ({exc})") from None

    def messages(self, keys: Iterable[str]) -> Iterator[tuple[str, Any, int]]:
        """``(key, message struct, log_time)`` for every valid message recorded on ``keys``."""
        for item in self.payloads(keys):
            cls = message_type(item.key)
            if cls is None:
                continue
            try:
                yield item.key, codec.decode(item.payload, cls), item.log_time
            except codec.MessageError:
                continue
