"""The ``ssc32`` driver: Lynxmotion SSC-32 and SSC-32U servo controllers (32 channels, ASCII).

Every pose is one group move (``#<ch>P<pw>S<spd>…T<ms>``, then a carriage return): the servos
start and stop together. ``S`` comes from the profile's ``max_speed`` (``--ssc32-speed-limits``)
and ``T`` from ``--ssc32-move-time``. On connect the driver asks for the firmware version; while
positions flow it asks ``Q`` once a second and reopens a board that stops answering.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Mapping
from typing import Annotated, Any

import msgspec

from facesynth.runtime.profiles import Profile
from facesynth.services.control.drivers.registry import DRIVERS
from facesynth.services.control.drivers.replies import ReplyQueue
from facesynth.services.control.drivers.serial_driver import AnswerClock, SerialServoDriver
from facesynth.services.control.drivers.serial_link import PORT_HELP
from facesynth.services.control.drivers.servo_map import ServoMap
from facesynth.services.control.drivers.ssc32 import protocol as sp

log = logging.getLogger("facesynth.control.ssc32")

ANSWER_TIMEOUT_S = 1.0
CHECK_EVERY_S = 1.0
REPLY_TIMEOUT_S = 2.0
#: A pose slower than this on the wire (a frame at 25 poses/s) gets a warning.
SLOW_POSE_MS = 40


class SSC32Config(
    msgspec.Struct, tag="ssc32", tag_field="driver", kw_only=True, forbid_unknown_fields=True
):
    """A Lynxmotion SSC-32 or SSC-32U (32 servos, ASCII group moves)."""

    port: Annotated[str, msgspec.Meta(description=PORT_HELP)]
    baud: Annotated[int, msgspec.Meta(gt=0, description="baud rate")] = 115200
    move_time_ms: (
        Annotated[
            int,
            msgspec.Meta(
                ge=1,
                le=sp.MAX_TIME_MS,
                description="T<ms> on every move: how long each move takes",
                extra={"flag": "--ssc32-move-time"},
            ),
        ]
        | None
    ) = None
    speed_limits: Annotated[
        bool,
        msgspec.Meta(
            description="S<us/s> on every servo from the profile's max_speed",
            extra={"flag": "--ssc32-speed-limits"},
        ),
    ] = True


@DRIVERS.register(SSC32Config)
class SSC32Driver(SerialServoDriver):
    """A Lynxmotion SSC-32/32U: one ASCII group move per pose."""

    board = "SSC-32"

    def __init__(self, config: SSC32Config, profile: Profile) -> None:
        servo_map = ServoMap(
            profile,
            board=self.board,
            step_us=1,
            range_us=(sp.MIN_US, sp.MAX_US),
            channels=sp.CHANNELS,
        )
        super().__init__(config.port, config.baud, servo_map, log)
        self.config = config
        self.speeds = (
            {s.channel: max(1, round(s.max_speed)) for s in profile.servos if s.max_speed > 0}
            if config.speed_limits
            else {}
        )
        pose_ms = len(sp.group_move(servo_map.neutral_pose(), self.speeds)) * 10 / config.baud * 1e3
        if pose_ms > SLOW_POSE_MS:
            log.warning(
                "%s: one pose takes %.0f ms on the wire at %d baud: the face will lag; set the "
                "SSC-32 to 115200 baud (and --baud 115200)",
                config.port,
                pose_ms,
                config.baud,
            )
        self.version = ""
        self._replies = ReplyQueue()
        self._answers = AnswerClock()
        self._last_check = 0.0

    def state(self) -> str:
        return "; ".join(p for p in (super().state(), self.version) if p)

    async def device_status(self) -> dict[str, Any]:
        """Firmware version, whether a move is running, each servo's pulse width (10 µs)."""
        self._require_connection()
        moving = await self._ask(sp.query_moving(), size=1)
        positions = {}
        for ch, lim in sorted(self.map.limits.items()):
            positions[lim.name] = (await self._ask(sp.query_pulse(ch), size=1))[0] * 10
        return {
            "port": self.link.port,
            "version": self.version,
            "moving": moving == b"+",
            "positions_us": positions,
        }

    async def _identify(self) -> None:
        self._replies.reset()
        self._answers.answered()
        answer = await self._ask(sp.version(), until=sp.CR)
        self.version = answer.strip().decode("ascii", "replace")
        self._last_check = time.monotonic()

    def _write_pose(self, pose: Mapping[int, int]) -> None:
        self.link.write(
            sp.group_move(self.map.checked(pose), self.speeds, self.config.move_time_ms)
        )
        now = time.monotonic()
        if self._answers.silent_for(now) > REPLY_TIMEOUT_S:
            self.link.lost(f"no answer to Q for {REPLY_TIMEOUT_S:g} s")
        elif now - self._last_check >= CHECK_EVERY_S and not self._replies.pending:
            self._last_check = now
            self._answers.sent(now)
            answer = self._replies.expect(size=1)
            self.link.write(sp.query_moving())
            answer.add_done_callback(self._check_answered)

    def _check_answered(self, answer: asyncio.Future[bytes]) -> None:
        if not answer.cancelled() and answer.exception() is None:
            self._answers.answered()

    def _received(self, data: bytes) -> None:
        self._replies.feed(data)

    async def _ask(
        self, command: bytes, *, size: int | None = None, until: bytes | None = None
    ) -> bytes:
        answer = self._replies.expect(size=size, until=until)
        self.link.write(command)
        try:
            return await asyncio.wait_for(answer, ANSWER_TIMEOUT_S)
        except TimeoutError:
            what = command.strip().decode("ascii", "replace")
            raise TimeoutError(
                f"no answer from the SSC-32 to {what} (check --baud: the SSC-32U ships at 9600)"
            ) from None
