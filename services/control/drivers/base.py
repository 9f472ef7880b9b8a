"""The servo driver seam: connect, send positions, go neutral, close."""

from __future__ import annotations

import abc
from collections.abc import Mapping

from facesynth.runtime.rig_view import RigView
from services.control.core import CommandInfo


class DriverError(RuntimeError):
    """A driver that cannot do what it was asked (device gone, file unwritable)."""


class ServoDriver(abc.ABC):
    """One output of the control interface: a servo board, a virtual face, a recorder."""

    def observe(self, rig: RigView) -> None:  # noqa: B027 - an optional hook
        """Optional: called once before :meth:`connect` with a read-only view of the rig.

        Drivers that show more than positions (the live face page shows frames, landmarks and
        stage latencies) subscribe through it; the others ignore it.
        """

    @abc.abstractmethod
    async def connect(self) -> None:
        """Open the device or file; raise :class:`DriverError` if it cannot be opened."""

    @abc.abstractmethod
    async def send(self, positions: Mapping[str, float], info: CommandInfo) -> None:
        """Move every named servo to its position (already clamped), in microseconds."""

    async def neutral(self, positions: Mapping[str, float]) -> None:
        """Return the face to neutral (``positions`` are the profile's neutral values)."""
        await self.send(positions, CommandInfo(frame=None, t_capture_ns=None, face=False))

    @abc.abstractmethod
    async def close(self) -> None:
        """Release the device or file."""
