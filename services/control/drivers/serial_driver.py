"""What every servo board driver on a serial link shares: the pose it holds, re-sent on reconnect.

A board driver keeps the pose the face should have (in board units, already clamped by its
:class:`~facesynth.services.control.drivers.servo_map.ServoMap`). :meth:`send` updates that pose and
writes it if the board is connected; while the board is away the pose still follows the
commands (including the control service's return to neutral), and the reconnect handshake
ends by writing it, so the face resumes where it should be.
"""

from __future__ import annotations

import abc
import logging
import time
from collections.abc import Mapping
from typing import Any

from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.base import DeviceUnavailable, ServoDriver
from facesynth.services.control.drivers.serial_link import SerialLink
from facesynth.services.control.drivers.servo_map import ServoMap


class SerialServoDriver(ServoDriver):
    """A servo board behind a :class:`SerialLink`; subclasses speak its protocol.

    Subclasses implement :meth:`_identify` (check the board, send its configuration; run on
    every connect), :meth:`_write_pose` (encode and write a pose) and :meth:`_received` (bytes
    from the board).
    """

    #: The board's name in messages.
    board = "servo board"

    def __init__(self, port: str, baud: int, servo_map: ServoMap, log: logging.Logger) -> None:
        self.map = servo_map
        self.log = log
        self.pose: dict[int, int] = servo_map.neutral_pose()
        self.link = SerialLink(
            port, baud, handshake=self._handshake, on_bytes=self._safely_received, log=log
        )
        self._error_logged = False
        #: Identify the board but do not configure or move it (``control status``).
        self.query_only = False

    async def connect(self) -> None:
        """Open the port; if it is not there yet, keep trying in the background."""
        await self.link.open(retry=True)

    async def connect_once(self, *, query_only: bool = False) -> None:
        """Open the port now or raise :class:`DeviceUnavailable`; with ``query_only`` the
        board is identified but neither configured nor moved."""
        self.query_only = query_only
        await self.link.open(retry=False)

    async def send(self, positions: Mapping[str, float], info: CommandInfo) -> None:
        """Update the pose; write it when the board is connected (dropped otherwise)."""
        self.pose = self.map.pose(positions, self.pose)
        if self.link.connected:
            self._write_pose(self.pose)
        elif not self.link.retrying:
            raise DeviceUnavailable(f"{self.link.port}: {self.link.state.describe()}")

    async def close(self) -> None:
        """Write out what is queued and close the port."""
        await self.link.close()

    def state(self) -> str:
        """The link's state (and the board's, from subclasses)."""
        return self.link.state.describe()

    def positions_us(self) -> dict[str, float]:
        """The pose the driver holds, in µs by servo name."""
        return {lim.name: self.map.us(self.pose[ch]) for ch, lim in self.map.limits.items()}

    def _require_connection(self) -> None:
        if not self.link.connected:
            raise DeviceUnavailable(f"{self.link.port}: {self.link.state.describe()}")

    async def _handshake(self, link: SerialLink) -> None:
        await self._identify()
        if not self.query_only:
            await self._configure()
            self._write_pose(self.pose)

    def _safely_received(self, data: bytes) -> None:
        try:
            self._received(data)
        except Exception:  # a bug here must not stop the control service
            if not self._error_logged:
                self._error_logged = True
                self.log.exception("%s: cannot handle bytes from the board", self.link.port)

    @abc.abstractmethod
    async def _identify(self) -> None:
        """Check the board (raise ``TimeoutError`` if it does not answer, and
        :class:`DriverConfigError` if it cannot drive the profile); no state changes."""

    async def _configure(self) -> None:
        """Send the board its configuration (after :meth:`_identify`, on every connect)."""

    @abc.abstractmethod
    def _write_pose(self, pose: Mapping[int, int]) -> None:
        """Encode ``pose`` (board units by channel) and write it."""

    @abc.abstractmethod
    def _received(self, data: bytes) -> None:
        """Bytes from the board."""

    @abc.abstractmethod
    async def device_status(self) -> dict[str, Any]:
        """What the board reports about itself."""


class AnswerClock:
    """Says when a board that should answer has been silent too long while being written to.

    ``sent(now)`` after each write that expects an answer, ``answered()`` on each answer;
    ``silent_for(now)`` is how long the oldest unanswered write has waited (0 if none).
    """

    def __init__(self) -> None:
        self._since: float | None = None

    def sent(self, now: float | None = None) -> None:
        if self._since is None:
            self._since = time.monotonic() if now is None else now

    def answered(self) -> None:
        self._since = None

    def silent_for(self, now: float | None = None) -> float:
        if self._since is None:
            return 0.0
        return (time.monotonic() if now is None else now) - self._since
