"""The ``maestro`` driver: Pololu Maestro servo controllers (compact protocol, quarter-µs).

The model decides the command: Set Multiple Targets on a Mini Maestro (12, 18, 24 channels),
one Set Target per channel otherwise. ``--maestro-model auto`` reads the model from the USB
product id of the port (a Maestro's own USB serial port); where that is not known (a TTL
serial adapter, ``socket://``) it uses Set Target, which every model understands.

On every connect the driver reads (and so clears) the error register, sends the profile's
``max_speed`` and ``max_accel`` as Set Speed / Set Acceleration (``--maestro-speed-limits``),
and writes the pose. While positions flow it reads the error register once a second: a
Maestro that reports an error has sent its servos home, so the pose is written again, and
one that stops answering is reopened.
"""

from __future__ import annotations

import asyncio
import logging
import os
import time
from collections.abc import Mapping
from typing import Annotated, Any, Literal

import msgspec

from facesynth.runtime.profiles import Profile
from facesynth.services.control.drivers.maestro import protocol as mp
from facesynth.services.control.drivers.registry import DRIVERS
from facesynth.services.control.drivers.replies import ReplyQueue
from facesynth.services.control.drivers.serial_driver import AnswerClock, SerialServoDriver
from facesynth.services.control.drivers.serial_link import PORT_HELP
from facesynth.services.control.drivers.servo_map import ServoMap

log = logging.getLogger("facesynth.control.maestro")

ANSWER_TIMEOUT_S = 0.5
CHECK_EVERY_S = 1.0
REPLY_TIMEOUT_S = 2.0
ModelName = Literal["auto", "micro6", "mini12", "mini18", "mini24"]


class MaestroConfig(
    msgspec.Struct, tag="maestro", tag_field="driver", kw_only=True, forbid_unknown_fields=True
):
    """A Pololu Maestro (Micro 6, Mini 12/18/24) over its USB or TTL serial port."""

    port: Annotated[str, msgspec.Meta(description=PORT_HELP)]
    baud: Annotated[int, msgspec.Meta(gt=0, description="baud rate")] = 115200
    model: Annotated[
        ModelName,
        msgspec.Meta(
            description="Maestro model: auto (from the USB id; else Set Target per channel), "
            "micro6, mini12, mini18, mini24",
            extra={"flag": "--maestro-model"},
        ),
    ] = "auto"
    speed_limits: Annotated[
        bool,
        msgspec.Meta(
            description="send the profile's max_speed/max_accel as the Maestro's speed and "
            "acceleration limits",
            extra={"flag": "--maestro-speed-limits"},
        ),
    ] = True
    detect_baud: Annotated[
        bool,
        msgspec.Meta(
            description="send the baud-rate byte 0xAA first (Maestro in 'UART, detect baud "
            "rate' mode)",
            extra={"flag": "--maestro-detect-baud"},
        ),
    ] = False


def usb_model(port: str) -> str | None:
    """The Maestro model behind a device path, from its USB ids (None if not a Maestro)."""
    if "://" in port:
        return None
    from serial.tools import list_ports

    device = os.path.realpath(port)
    for info in list_ports.comports():
        if os.path.realpath(info.device) == device and info.vid == mp.USB_VENDOR:
            return mp.USB_PRODUCTS.get(info.pid or 0)
    return None


@DRIVERS.register(MaestroConfig)
class MaestroDriver(SerialServoDriver):
    """A Pololu Maestro: Set Multiple Targets or Set Target, quarter-µs, speed limits."""

    board = "Pololu Maestro"

    def __init__(self, config: MaestroConfig, profile: Profile) -> None:
        self.model = mp.MODELS.get(config.model)
        channels = (
            self.model.channels if self.model else max(m.channels for m in mp.MODELS.values())
        )
        servo_map = ServoMap(
            profile,
            board=self.model.name if self.model else "Maestro (largest: 24 channels)",
            step_us=0.25,
            range_us=(0.25, mp.MAX_PULSE_US),
            channels=channels,
        )
        super().__init__(config.port, config.baud, servo_map, log)
        self.config = config
        self.speeds = {
            spec.channel: (mp.speed_units(spec.max_speed), mp.acceleration_units(spec.max_accel))
            for spec in profile.servos
        }
        self.errors_seen: dict[str, int] = {}
        self._replies = ReplyQueue()
        self._answers = AnswerClock()
        self._last_check = 0.0
        self._said_model = False

    @property
    def multiple_targets(self) -> bool:
        """Whether poses go out as Set Multiple Targets."""
        return self.model is not None and self.model.multiple_targets

    def state(self) -> str:
        parts = [super().state(), self.model.name if self.model else "model unknown"]
        if self.errors_seen:
            parts.append("errors " + ", ".join(f"{k} {v}x" for k, v in self.errors_seen.items()))
        return "; ".join(parts)

    async def device_status(self) -> dict[str, Any]:
        """The error register (read and cleared) and each servo's position."""
        self._require_connection()
        errors = await self._get_errors()
        positions = {}
        for ch, lim in sorted(self.map.limits.items()):
            answer = await self._ask(mp.get_position(ch), size=2)
            positions[lim.name] = mp.u16(answer) / 4
        return {
            "port": self.link.port,
            "model": self.model.name if self.model else "unknown (Set Target per channel)",
            "errors": mp.error_names(errors) or ["none"],
            "positions_us": positions,
        }

    async def _identify(self) -> None:
        self._replies.reset()
        self._answers.answered()
        if self.config.detect_baud:
            self.link.write(bytes((mp.BAUD_INDICATION,)))
        if self.config.model == "auto":
            found = await asyncio.to_thread(usb_model, self.link.port)
            self.model = mp.MODELS[found] if found else None
            if self.model is not None:
                self.map.check_channels(self.model.channels, self.model.name)
            elif not self._said_model:
                self._said_model = True
                log.info(
                    "%s: Maestro model unknown (not its USB port): one Set Target per channel; "
                    "--maestro-model mini12|mini18|mini24 sends Set Multiple Targets",
                    self.link.port,
                )
        if not self.query_only:  # (reading the errors clears them: status reads them itself)
            errors = await self._get_errors()
            if errors:
                log.warning(
                    "%s: the Maestro reported %s (now cleared)",
                    self.link.port,
                    ", ".join(mp.error_names(errors)),
                )

    async def _configure(self) -> None:
        if self.config.speed_limits:
            out = bytearray()
            for ch, (speed, accel) in sorted(self.speeds.items()):
                out += mp.set_speed(ch, speed) + mp.set_acceleration(ch, accel)
            self.link.write(bytes(out))
        self._last_check = time.monotonic()

    def _write_pose(self, pose: Mapping[int, int]) -> None:
        self.link.write(mp.targets(self.map.checked(pose), self.multiple_targets))
        now = time.monotonic()
        if self._answers.silent_for(now) > REPLY_TIMEOUT_S:
            self.link.lost(f"no answer to Get Errors for {REPLY_TIMEOUT_S:g} s")
        elif now - self._last_check >= CHECK_EVERY_S and not self._replies.pending:
            self._last_check = now
            self._answers.sent(now)
            answer = self._replies.expect(size=2)
            self.link.write(mp.get_errors())
            answer.add_done_callback(self._checked_errors)

    def _checked_errors(self, answer: asyncio.Future[bytes]) -> None:
        if answer.cancelled() or answer.exception() is not None:
            return
        self._answers.answered()
        names = mp.error_names(mp.u16(answer.result()))
        if names:
            for name in names:
                self.errors_seen[name] = self.errors_seen.get(name, 0) + 1
            log.warning(
                "%s: the Maestro reported %s; writing the pose again", self.link.port, names
            )
            if self.link.connected:
                self._write_pose(self.pose)

    def _received(self, data: bytes) -> None:
        self._replies.feed(data)

    async def _get_errors(self) -> int:
        return mp.u16(await self._ask(mp.get_errors(), size=2))

    async def _ask(self, command: bytes, *, size: int) -> bytes:
        answer = self._replies.expect(size=size)
        self.link.write(command)
        try:
            return await asyncio.wait_for(answer, ANSWER_TIMEOUT_S)
        except TimeoutError:
            raise TimeoutError(f"no answer from the Maestro to 0x{command[0]:02x}") from None
