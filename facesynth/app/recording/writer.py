"""A chunked MCAP session file that survives a kill: all but the chunk in progress is on disk.

Messages collect in a chunk in memory; a chunk is cut when it reaches ``chunk_bytes`` or has
been open ``chunk_seconds``, whichever comes first, compressed, written and (by default)
fsynced at once. A killed recorder therefore loses at most the chunk in progress (at most
``chunk_seconds`` of data), and ``facesynth record --check`` recovers everything before it.

Memory stays bounded on long sessions: the chunk in progress (``chunk_bytes`` plus its
message index) and one small index record per chunk written (the summary needs them).
"""

from __future__ import annotations

import collections
import contextlib
import os
import queue
import threading
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import IO

import mcap
from mcap.writer import CompressionType, Writer

from facesynth import __version__
from facesynth.app.recording.layout import METADATA_NAME, PROFILE, ChannelSpec, Entry
from facesynth.app.recording.views import SchemaSpec

COMPRESSIONS = {
    "zstd": CompressionType.ZSTD,
    "lz4": CompressionType.LZ4,
    "none": CompressionType.NONE,
}

#: Library string in every file's header.
LIBRARY = f"facesynth {__version__} (mcap {mcap.__version__})"


class RecordingFileError(ValueError):
    """A recording that cannot be created (folder missing, file exists, bad option)."""


class SessionWriter:
    """Writes :class:`Entry` records to ``path`` (see the module docstring for the guarantees)."""

    def __init__(
        self,
        path: str | Path,
        *,
        metadata: Mapping[str, str],
        chunk_bytes: int = 1 << 20,
        chunk_seconds: float = 1.0,
        compression: str = "zstd",
        fsync: bool = True,
        overwrite: bool = False,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        if chunk_bytes < 1024:
            raise RecordingFileError("the chunk size must be at least 1024 bytes")
        if not chunk_seconds > 0:
            raise RecordingFileError("the chunk time must be positive")
        if compression not in COMPRESSIONS:
            raise RecordingFileError(
                f"unknown compression {compression!r}; use {', '.join(COMPRESSIONS)}"
            )
        self.path = Path(path)
        self.chunk_seconds = chunk_seconds
        self.fsync = fsync
        self._clock = clock
        try:
            self._file: IO[bytes] = open(self.path, "wb" if overwrite else "xb")  # noqa: SIM115
        except FileExistsError:
            raise RecordingFileError(
                f"{self.path} exists (give --overwrite to replace it)"
            ) from None
        except OSError as exc:
            raise RecordingFileError(f"cannot create {self.path}: {exc.strerror or exc}") from None
        self._writer = Writer(
            self._file, chunk_size=chunk_bytes, compression=COMPRESSIONS[compression]
        )
        self._writer.start(profile=PROFILE, library=LIBRARY)
        self._writer.add_metadata(METADATA_NAME, dict(metadata))
        self._sync()
        self._schemas: dict[SchemaSpec, int] = {}
        self._channels: dict[ChannelSpec, int] = {}
        self._chunk_opened: float | None = None
        self._closed = False
        #: Messages written, by topic.
        self.counts: collections.Counter[str] = collections.Counter()
        self.chunks = 0

    @property
    def messages(self) -> int:
        """Messages written so far."""
        return sum(self.counts.values())

    def _channel_id(self, spec: ChannelSpec) -> int:
        channel_id = self._channels.get(spec)
        if channel_id is None:
            schema_id = 0
            if spec.schema is not None:
                schema_id = self._schemas.get(spec.schema, 0)
                if not schema_id:
                    schema_id = self._writer.register_schema(
                        spec.schema.name, spec.schema.encoding, spec.schema.data
                    )
                    self._schemas[spec.schema] = schema_id
            channel_id = self._writer.register_channel(
                spec.topic, spec.message_encoding, schema_id, spec.metadata()
            )
            self._channels[spec] = channel_id
        return channel_id

    def write(self, entry: Entry) -> None:
        """Add one message; cuts the chunk when it is full (and then flushes it to disk)."""
        if self._closed:
            raise RecordingFileError(f"{self.path} is closed")
        before = self._file.tell()
        self._writer.add_message(
            self._channel_id(entry.channel),
            log_time=entry.log_time,
            data=entry.data,
            publish_time=entry.publish_time,
            sequence=entry.sequence & 0xFFFFFFFF,
        )
        self.counts[entry.channel.topic] += 1
        if self._file.tell() != before:  # the writer cut a full chunk into the stream
            self.chunks += 1
            self._chunk_opened = None
            self._sync()
        elif self._chunk_opened is None:
            self._chunk_opened = self._clock()

    def tick(self) -> bool:
        """Cut the chunk in progress if it has been open ``chunk_seconds``; whether it did."""
        opened = self._chunk_opened
        if opened is None or self._clock() - opened < self.chunk_seconds:
            return False
        self.cut()
        return True

    def cut(self) -> None:
        """Write the chunk in progress now (nothing happens when it is empty)."""
        if self._chunk_opened is None:
            return
        self._writer.flush()
        self.chunks += 1
        self._chunk_opened = None
        self._sync()

    def _sync(self) -> None:
        self._file.flush()
        if self.fsync:
            os.fsync(self._file.fileno())

    def close(self) -> None:
        """Write the last chunk, the indexes and the summary; the file is then complete."""
        if self._closed:
            return
        self._closed = True
        try:
            if self._chunk_opened is not None:
                self.chunks += 1
            self._writer.finish()
            self._file.flush()
            os.fsync(self._file.fileno())
        finally:
            self._file.close()


class WriterThread:
    """Runs a :class:`SessionWriter` on a thread of its own.

    Cutting a chunk (compressing and fsyncing about 1 MB) takes several milliseconds, up to
    tens; on its own thread it never stalls the event loop the chain's stages may share
    (``run --record``). At most ``maxsize`` entries wait; beyond that an entry is refused and
    counted in ``refused`` (a disk that cannot keep up), never buffered without bound. An error
    of the writer (disk full) is raised on the caller's side by :meth:`check` and :meth:`close`.
    """

    _TICK = object()
    _STOP = object()

    def __init__(self, writer: SessionWriter, maxsize: int = 8192) -> None:
        self.writer = writer
        self.refused = 0
        self.error: BaseException | None = None
        self._queue: queue.Queue[object] = queue.Queue(maxsize)
        self._thread = threading.Thread(target=self._run, name="session-writer", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while True:
            item = self._queue.get()
            if item is self._STOP:
                return
            if self.error is not None:
                continue
            try:
                if item is self._TICK:
                    self.writer.tick()
                else:
                    self.writer.write(item)  # type: ignore[arg-type]
            except BaseException as exc:  # kept for the caller: the thread must not die silently
                self.error = exc

    def write(self, entry: Entry) -> None:
        """Queue one entry (refused, and counted, when the queue is full)."""
        self.check()
        try:
            self._queue.put_nowait(entry)
        except queue.Full:
            self.refused += 1

    def tick(self) -> None:
        """Ask the writer to cut a chunk that has been open long enough."""
        self.check()
        with contextlib.suppress(queue.Full):
            self._queue.put_nowait(self._TICK)

    def check(self) -> None:
        """Raise the writer's error, if it had one."""
        if self.error is not None:
            raise RecordingFileError(f"cannot write {self.writer.path}: {self.error}")

    def close(self) -> None:
        """Write what is queued, then complete the file."""
        self._queue.put(self._STOP)
        self._thread.join()
        self.writer.close()
        self.check()
