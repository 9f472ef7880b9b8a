"""A fake Lynxmotion SSC-32U, from the SSC-32U User Guide ("Commands").

Commands are ASCII lines ended by a carriage return; spaces, tabs and line feeds are ignored;
case does not matter. ``#<ch>P<pw>[S<spd>]…[T<time>]`` moves one or more servos together
(channels 0..31, pulse widths 500..2500 µs); ``VER`` answers the version, ``Q`` answers
``.`` (no move running: this fake moves at once), ``QP <ch>`` answers one byte per channel,
the pulse width / 10. A line the board does not understand is ignored.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from fake_devices.pty_device import FakeDevice

VERSION = b"SSC32-V2.50USB"
_SERVO = re.compile(r"#(\d+)P(\d+)(?:S(\d+))?")
_MOVE = re.compile(r"(?:#\d+P\d+(?:S\d+)?)+(?:T\d+)?")


@dataclass
class Move:
    """One group move: pulse widths and speeds by channel, and the group's time."""

    widths: dict[int, int]
    speeds: dict[int, int] = field(default_factory=dict)
    time_ms: int | None = None


class FakeSSC32(FakeDevice):
    """An SSC-32U with 32 channels."""

    def __init__(self, link: Path) -> None:
        super().__init__(link)
        self.reset()

    def reset(self) -> None:
        super().reset()
        self.widths: dict[int, int] = {}  # channels never set send no pulses
        self.moves: list[Move] = []
        self.ignored: list[str] = []
        self.queries: list[str] = []
        self._line = bytearray()

    def handle(self, data: bytes) -> bytes:
        out = bytearray()
        for byte in data:
            if byte == 0x0D:
                out += self._execute(self._line.decode("ascii", "replace"))
                self._line.clear()
            elif byte not in b" \t\n":
                self._line.append(byte)
        return bytes(out)

    def _execute(self, line: str) -> bytes:
        text = line.upper()
        if text == "VER":
            self.queries.append(text)
            return VERSION + b"\r"
        if text == "Q":
            self.queries.append(text)
            return b"."
        if text.startswith("QP"):
            self.queries.append(text)
            channels = [int(c) for c in re.findall(r"QP(\d+)", text)]
            return bytes(self.widths.get(ch, 0) // 10 for ch in channels)
        if _MOVE.fullmatch(text):
            servos = _SERVO.findall(text)
            widths = {int(ch): int(pw) for ch, pw, _ in servos}
            if all(ch < 32 and 500 <= pw <= 2500 for ch, pw in widths.items()):
                speeds = {int(ch): int(s) for ch, _, s in servos if s}
                time = re.search(r"T(\d+)$", text)
                self.moves.append(Move(widths, speeds, int(time.group(1)) if time else None))
                self.widths.update(widths)
                return b""
        self.ignored.append(line)
        return b""
