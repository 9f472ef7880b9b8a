"""The ``record`` driver: one JSON line per command, flushed, so a kill loses at most one line.

A record file is never truncated: each time the driver connects it appends a *session marker*
line (``{"session": {...}}``: when, which profile, which process) and then its command lines,
so a control interface restarted on the same ``--out`` (as ``docker-compose.yml`` does) keeps
every earlier session. A line torn by a kill is closed with a newline before the next session
starts. :func:`read_record` reads every session's lines, :func:`read_sessions` them session by
session; both skip torn lines and refuse any other broken line with :class:`RecordError`.
"""

from __future__ import annotations

import logging
import os
import re
import socket
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Annotated

import msgspec

from facesynth.runtime.outputs import OutputError, check_output
from facesynth.runtime.profiles import Profile
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.base import DriverConfigError, DriverError, ServoDriver
from facesynth.services.control.drivers.registry import DRIVERS
from facesynth.services.control.drivers.servo_map import ProfileLimits

log = logging.getLogger("facesynth.control")
_MARKER = re.compile(rb'^\{\s*"session"\s*:')  # a session marker line, not decoded


class RecordConfig(
    msgspec.Struct, tag="record", tag_field="driver", kw_only=True, forbid_unknown_fields=True
):
    """Record every command to a JSON-lines file."""

    out: Annotated[str, msgspec.Meta(description="JSON-lines file the commands are written to")]


class RecordLine(msgspec.Struct, kw_only=True):
    """One recorded command (the format: docs/drivers.md)."""

    seq: int
    frame: int | None
    t_capture_ns: int | None
    t_sent_ns: int
    face: bool
    servos: dict[str, float]


class SessionInfo(msgspec.Struct, kw_only=True):
    """What a session marker says about the session that follows it."""

    started_ns: int
    profile: str = ""
    host: str = ""
    pid: int = 0


class SessionMarker(msgspec.Struct, kw_only=True, forbid_unknown_fields=True):
    """The line that starts a session: ``{"session": {...}}``."""

    session: SessionInfo


class RecordError(ValueError):
    """A record file that cannot be read back; the message names the file and the line."""


@DRIVERS.register(RecordConfig)
class RecordDriver(ServoDriver):
    """Record every command as a JSON line (seq, frame, times, face, servos), flushed."""

    moves_hardware = False

    def __init__(self, config: RecordConfig, profile: Profile | None = None) -> None:
        try:  # before the service connects or waits for its router: say it now
            self.path = check_output(config.out, "record file")
        except OutputError as exc:
            raise DriverConfigError(str(exc)) from None
        self._file: IO[bytes] | None = None
        self._encoder = msgspec.json.Encoder()
        self.count = 0
        self.profile = profile.name if profile else ""
        #: With a profile, positions are checked and clamped like a board's (the safety
        #: contract every driver keeps); without, they are recorded as given.
        self.limits = ProfileLimits(profile) if profile else None

    async def connect(self) -> None:
        marker = SessionMarker(
            session=SessionInfo(
                started_ns=time.time_ns(),
                profile=self.profile,
                host=socket.gethostname(),
                pid=os.getpid(),
            )
        )
        try:
            earlier = earlier_sessions(self.path)
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file = open(self.path, "ab")  # noqa: SIM115 - kept open for the run
            if self._file.tell() > 0 and not _ends_with_newline(self.path):
                self._file.write(b"\n")  # close a line a kill tore: it stays unreadable
            self._file.write(self._encoder.encode(marker) + b"\n")
            self._file.flush()
        except OSError as exc:
            self._file = None
            raise DriverError(f"cannot open record file {self.path}: {exc}") from None
        self.count = 0
        log.info("%s", describe_record_file(self.path, earlier))

    async def send(self, positions: Mapping[str, float], info: CommandInfo) -> None:
        if self._file is None:
            raise DriverError("record driver is not connected")
        checked = self.limits.clamp(positions) if self.limits else dict(positions)
        line = RecordLine(
            seq=self.count,
            frame=info.frame,
            t_capture_ns=info.t_capture_ns,
            t_sent_ns=info.t_ns if info.t_ns is not None else time.time_ns(),
            face=info.face,
            servos={name: round(value, 3) for name, value in checked.items()},
        )
        try:
            self._file.write(self._encoder.encode(line) + b"\n")
            self._file.flush()
        except OSError as exc:
            raise DriverError(f"cannot write record file {self.path}: {exc}") from None
        self.count += 1

    async def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None


def earlier_sessions(path: str | Path) -> int:
    """How many sessions a record file holds before the next one is appended (0: the file
    does not exist, is empty or cannot be read: opening it says why). Lines written before
    session markers existed count as one session; the lines are not decoded."""
    sessions = 0
    try:
        with open(path, "rb") as handle:
            for number, raw in enumerate(handle):
                if _MARKER.match(raw):
                    sessions += 1
                elif number == 0 and raw.strip():
                    sessions += 1  # commands before the first marker: a file from before them
    except OSError:  # none yet, or unreadable: opening it for the session says why
        return 0
    return sessions


def describe_record_file(path: str | Path, earlier: int) -> str:
    """One line on what a session did to its record file: created it, or appended to it."""
    if earlier == 0:
        return f"record file {path}: created (one session)"
    s = "" if earlier == 1 else "s"
    return (
        f"record file {path}: appended session {earlier + 1} after {earlier} earlier "
        f"session{s} (a record file is never truncated)"
    )


def record_summary(path: str | Path, earlier: int) -> dict[str, object]:
    """A run summary's ``record`` entry: the file, ``"created"`` or ``"appended"``, and the
    sessions it now holds."""
    return {
        "out": str(path),
        "file": "appended" if earlier else "created",
        "sessions": earlier + 1,
    }


def _ends_with_newline(path: Path) -> bool:
    with open(path, "rb") as handle:
        handle.seek(-1, os.SEEK_END)
        return handle.read(1) == b"\n"


@dataclass
class Session:
    """One session of a record file: its marker (``None`` for lines written before markers
    existed) and its command lines."""

    info: SessionInfo | None
    lines: list[RecordLine] = field(default_factory=list)
    #: Lines a kill tore (skipped).
    torn: int = 0


def read_sessions(path: str | Path) -> list[Session]:
    """Every session of a record file, in order.

    A line a kill tore (the last line of the file without a newline, or an unreadable line
    right before a session marker) is skipped and counted; any other line that is neither a
    command nor a marker raises :class:`RecordError`.
    """
    lines = _decoded_lines(Path(path))
    sessions: list[Session] = []
    for number, item in enumerate(lines, start=1):
        if isinstance(item, SessionMarker):
            sessions.append(Session(item.session))
            continue
        if not sessions:
            sessions.append(Session(None))  # a file from before markers
        if isinstance(item, RecordLine):
            sessions[-1].lines.append(item)
            continue
        follows = lines[number] if number < len(lines) else None
        if item is _TORN_AT_END or isinstance(follows, SessionMarker):
            sessions[-1].torn += 1
            continue
        raise RecordError(f"{path}: line {number} is neither a command nor a session marker")
    return sessions


def read_record(path: str | Path, session: int | None = None) -> list[RecordLine]:
    """The command lines of every session of a record file (or of ``session`` only: 0 the
    first, -1 the last), torn lines skipped (see :func:`read_sessions`)."""
    sessions = read_sessions(path)
    if session is not None:
        try:
            return sessions[session].lines
        except IndexError:
            raise RecordError(f"{path} has {len(sessions)} sessions, not {session}") from None
    return [line for item in sessions for line in item.lines]


_TORN_AT_END = object()
_UNREADABLE = object()


def _decoded_lines(path: Path) -> list[object]:
    lines = Decoder()
    try:
        with open(path, "rb") as handle:
            return [lines.decode(raw) for raw in handle]
    except OSError as exc:
        raise RecordError(f"cannot read record file {path}: {exc}") from None


class Decoder:
    """One record file line: a :class:`RecordLine`, a :class:`SessionMarker`, or unreadable."""

    def __init__(self) -> None:
        self._line = msgspec.json.Decoder(RecordLine)
        self._marker = msgspec.json.Decoder(SessionMarker)

    def decode(self, raw: bytes) -> object:
        if not raw.endswith(b"\n"):
            return _TORN_AT_END
        for decoder in (self._line, self._marker):
            try:
                return decoder.decode(raw)
            except (msgspec.DecodeError, msgspec.ValidationError, UnicodeDecodeError):
                continue
        return _UNREADABLE
