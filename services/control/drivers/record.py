"""The ``record`` driver: one JSON line per command, flushed, so a kill loses at most one line."""

from __future__ import annotations

import time
from collections.abc import Mapping
from pathlib import Path
from typing import IO, Annotated

import msgspec

from facesynth.runtime.profiles import Profile
from services.control.core import CommandInfo
from services.control.drivers.base import DriverError, ServoDriver
from services.control.drivers.registry import DRIVERS
from services.control.drivers.servo_map import ProfileLimits


class RecordConfig(
    msgspec.Struct, tag="record", tag_field="driver", kw_only=True, forbid_unknown_fields=True
):
    """Record every command to a JSON-lines file."""

    out: Annotated[str, msgspec.Meta(description="JSON-lines file the commands are written to")]


class RecordLine(msgspec.Struct, kw_only=True):
    """One recorded command (see the README for the format)."""

    seq: int
    frame: int | None
    t_capture_ns: int | None
    t_sent_ns: int
    face: bool
    servos: dict[str, float]


@DRIVERS.register(RecordConfig)
class RecordDriver(ServoDriver):
    """Record every command as a JSON line (seq, frame, times, face, servos), flushed."""

    def __init__(self, config: RecordConfig, profile: Profile | None = None) -> None:
        self.path = Path(config.out)
        self._file: IO[bytes] | None = None
        self._encoder = msgspec.json.Encoder()
        self.count = 0
        #: With a profile, positions are checked and clamped like a board's (the safety
        #: contract every driver keeps); without, they are recorded as given.
        self.limits = ProfileLimits(profile) if profile else None

    async def connect(self) -> None:
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file = open(self.path, "wb")  # noqa: SIM115 - kept open for the run
        except OSError as exc:
            raise DriverError(f"cannot open record file {self.path}: {exc}") from None

    async def send(self, positions: Mapping[str, float], info: CommandInfo) -> None:
        if self._file is None:
            raise DriverError("record driver is not connected")
        checked = self.limits.clamp(positions) if self.limits else dict(positions)
        line = RecordLine(
            seq=self.count,
            frame=info.frame,
            t_capture_ns=info.t_capture_ns,
            t_sent_ns=time.time_ns(),
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


def read_record(path: str | Path) -> list[RecordLine]:
    """Read a record file back (a torn last line from a kill is ignored)."""
    decoder = msgspec.json.Decoder(RecordLine)
    lines = []
    with open(path, "rb") as handle:
        for raw in handle:
            if not raw.endswith(b"\n"):
                break
            lines.append(decoder.decode(raw))
    return lines
