"""The servo driver seam: connect, send positions, go neutral, close."""

from __future__ import annotations

import abc
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from types import TracebackType
from typing import Any, ClassVar, Self

from facesynth.runtime.rig_view import RigView
from facesynth.services.control.core import CommandInfo


class DriverError(RuntimeError):
    """A driver that cannot do what it was asked (device gone, file unwritable)."""


class DriverConfigError(DriverError, ValueError):
    """A driver setting, profile or device that cannot work together; one line, said at connect.

    A ``ValueError`` too, so the command line prints it as ``facesynth CMD: error: …``.
    """


class DeviceUnavailable(DriverError, ValueError):
    """The device cannot be opened or does not answer (bring-up tools fail with this at once)."""


@dataclass(frozen=True, slots=True)
class ServoReading:
    """What one servo reports of itself (smart bus servos: Dynamixel, Feetech).

    ``position_us`` is the measured position in the profile's microseconds; ``load`` the signed
    load as a fraction of the servo's maximum (None: not reported); ``temperature_c`` in degrees
    Celsius (None: not reported); ``fault`` one line on a hardware error the servo reports
    (overload, overheating, voltage), empty while there is none.
    """

    position_us: float
    load: float | None = None
    temperature_c: float | None = None
    fault: str = ""


@dataclass(frozen=True, slots=True)
class FoundDevice:
    """One device a driver found on its bus, for ``facesynth doctor``.

    ``address`` is where it answered (``id 3`` on a servo bus, ``0x40`` on I2C), ``model``
    what it says it is, ``servo`` the profile's servo that expects it there (empty: none), and
    ``problem`` one line when it cannot serve that servo (another model than the profile's),
    empty when it can.
    """

    address: str
    model: str
    servo: str = ""
    problem: str = ""


class ServoDriver(abc.ABC):
    """One output of the control interface: a servo board, a virtual face, a recorder.

    A driver is an async context manager: ``async with driver:`` connects it and closes it on
    the way out, whatever happened. It does not move the face on exit: returning to neutral is
    the control interface's decision, made before the driver closes.
    """

    #: Whether the driver moves something physical (a servo board): the control interface then
    #: always measures speed limits in real time, even in a ``--fast`` replay. Drivers whose
    #: output is a file or a picture (``record``, ``virtual``, ``vmc``) say False.
    moves_hardware: ClassVar[bool] = True
    #: The profile the driver expects when a node names none (``vmc``: ``arkit52``); None: the
    #: chain's default (``paper16``). The command line says in one log line when it is used.
    expected_profile: ClassVar[str | None] = None
    #: The control names the driver can show; None: any (a servo board drives every channel, a
    #: page draws a bar for every control). A profile with others is refused before it runs.
    shown_controls: ClassVar[frozenset[str] | None] = None
    #: What :attr:`shown_controls` are, in words, for the refusal.
    shown_controls_described: ClassVar[str] = "any control"
    #: The ``facesynth`` extra whose packages it imports when built (``facesynth doctor`` checks
    #: that a graph's plugins have theirs); None: no extra.
    needs_extra: ClassVar[str | None] = None

    @classmethod
    def unshown_controls(cls, names: Iterable[str]) -> list[str]:
        """Those of ``names`` the driver cannot show, in their order (none when it shows any)."""
        if cls.shown_controls is None:
            return []
        return [name for name in names if name not in cls.shown_controls]

    async def __aenter__(self) -> Self:
        await self.connect()
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        await self.close()

    def observe(self, rig: RigView) -> None:  # noqa: B027 - an optional hook
        """Optional: called once before :meth:`connect` with a read-only view of the rig.

        Drivers that show more than positions (the live face page shows frames, landmarks and
        stage latencies) subscribe through it; the others ignore it.
        """

    @abc.abstractmethod
    async def connect(self) -> None:
        """Open the device or file; raise :class:`DriverError` if it cannot be opened.

        Drivers of devices that can be unplugged may instead keep trying in the background
        (and say so in :meth:`state`); settings that can never work raise
        :class:`DriverConfigError`.
        """

    async def connect_once(self, *, query_only: bool = False) -> None:
        """Open for a one-off task (bring-up tools): fail at once rather than keep trying.

        With ``query_only`` the device is only asked questions (``control status``): it is
        neither configured nor moved.
        """
        await self.connect()

    @abc.abstractmethod
    async def send(self, positions: Mapping[str, float], info: CommandInfo) -> None:
        """Move every named servo to its position (already clamped), in microseconds."""

    async def neutral(self, positions: Mapping[str, float]) -> None:
        """Return the face to neutral (``positions`` are the profile's neutral values)."""
        await self.send(positions, CommandInfo(frame=None, t_capture_ns=None, face=False))

    @abc.abstractmethod
    async def close(self) -> None:
        """Release the device or file."""

    def readings(self) -> Mapping[str, ServoReading]:
        """The latest reading of each servo that reports itself, by servo name.

        Empty for drivers that cannot read their servos back (the Maestro, the SSC-32, our
        firmware, files and pages). Called by the control interface after each send; it must
        not wait on the device (a driver reads in the background and returns what it has).
        """
        return {}

    async def found(self) -> list[FoundDevice]:
        """What answers on the device's bus (``facesynth doctor``, after ``connect_once(
        query_only=True)``): ids and models of the servos, or the board itself, read only.

        Drivers without a bus to look at return an empty list (doctor then lists nothing).
        """
        return []

    def state(self) -> str:
        """One line on the device's state for the service's stats (empty: nothing to say)."""
        return ""

    async def device_status(self) -> dict[str, Any]:
        """What the device reports about itself (``facesynth control status``)."""
        raise DriverConfigError(f"the {type(self).__name__} has no device to query")
