"""The ``arduino`` driver: an Uno running facesynth's servo firmware (``firmware/PROTOCOL.md``).

On every connect it pings until the firmware answers (an Uno resets when its port opens),
checks the protocol version and the channel count, continues the sequence numbers from the
board's ``last_seq``, and sends the firmware watchdog and the profile's limits, neutral and
rate limit (``max_speed`` × 20 ms per step). Positions go out as SET_ALL (the profile covers
every channel) or SET_SOME, one frame per write; replies are read as they come. An ACK
without LIMITS_SET means the board reset: the configuration and the pose are sent again. A
STALE_SEQUENCE NACK resynchronises the sequence numbers from STATUS.
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import functools
import logging
from collections.abc import Callable, Coroutine, Mapping
from typing import Annotated, Any

import msgspec

from facesynth.runtime.profiles import Profile
from facesynth.services.control.drivers.arduino import protocol as proto
from facesynth.services.control.drivers.arduino import replies
from facesynth.services.control.drivers.base import DriverConfigError, DriverError
from facesynth.services.control.drivers.registry import DRIVERS
from facesynth.services.control.drivers.serial_driver import AnswerClock, SerialServoDriver
from facesynth.services.control.drivers.serial_link import PORT_HELP
from facesynth.services.control.drivers.servo_map import ServoMap

log = logging.getLogger("facesynth.control.arduino")

#: Seconds the firmware may leave commands unanswered before the port is reopened.
REPLY_TIMEOUT_S = 2.0
#: Seconds to wait for the ACK of a configuration command.
ACK_TIMEOUT_S = 0.5
PING_INTERVAL_S = 0.2
QUIET_S = proto.FRAME_TIMEOUT_MS / 1000


class ArduinoConfig(
    msgspec.Struct, tag="arduino", tag_field="driver", kw_only=True, forbid_unknown_fields=True
):
    """An Arduino Uno running the facesynth servo firmware (PCA9685: 16 servos; pins: 12)."""

    port: Annotated[str, msgspec.Meta(description=PORT_HELP)]
    baud: Annotated[int, msgspec.Meta(gt=0, description="baud rate")] = 115200
    board_watchdog_ms: Annotated[
        int,
        msgspec.Meta(
            ge=proto.WATCHDOG_MIN_MS,
            le=proto.WATCHDOG_MAX_MS,
            description="the firmware's own watchdog: neutral after this many ms without "
            "positions (20-60000)",
        ),
    ] = proto.WATCHDOG_DEFAULT_MS
    connect_timeout: Annotated[
        float,
        msgspec.Meta(
            gt=0,
            description="seconds to wait for the firmware after opening the port "
            "(an Uno resets when it is opened)",
        ),
    ] = 3.0


def firmware_limits(profile: Profile, servo_map: ServoMap) -> dict[int, proto.Limits]:
    """The SET_LIMITS entries of a profile: limits rounded inward, ``max_speed`` as µs per
    20 ms (0 = no rate limit); :class:`DriverConfigError` for what the firmware would refuse."""
    out: dict[int, proto.Limits] = {}
    for spec in profile.servos:
        lim = servo_map.limits[spec.channel]
        step = round(spec.max_speed * proto.STEP_PERIOD_MS / 1000) if spec.max_speed > 0 else 0
        if spec.max_speed > 0:
            step = max(1, step) if step <= 0xFFFF else 0  # beyond u16: not a limit at all
        limits = proto.Limits(lim.low, lim.neutral, lim.high, step)
        problems = limits.problems()
        if problems:
            raise DriverConfigError(f"servo {spec.name!r}: {'; '.join(problems)}")
        out[spec.channel] = limits
    return out


def limits_frame(seq: int, limits: Mapping[int, proto.Limits]) -> bytes:
    """SET_LIMITS for up to 16 channels."""
    return proto.set_limits(seq, limits)


def pose_frame(seq: int, pose: Mapping[int, int], channels: int) -> bytes:
    """SET_ALL when ``pose`` covers channels 0..channels-1, else SET_SOME."""
    if len(pose) == channels and all(ch in pose for ch in range(channels)):
        return proto.set_all(seq, [pose[ch] for ch in range(channels)])
    return proto.set_some(seq, dict(sorted(pose.items())))


@DRIVERS.register(ArduinoConfig)
class ArduinoDriver(SerialServoDriver):
    """An Uno with the facesynth servo firmware (binary frames with CRC, acknowledged)."""

    board = "facesynth servo firmware"

    def __init__(self, config: ArduinoConfig, profile: Profile) -> None:
        servo_map = ServoMap(
            profile,
            board=self.board,
            step_us=1,
            range_us=(proto.US_ABS_MIN, proto.US_ABS_MAX),
            channels=proto.MAX_CHANNELS,
        )
        super().__init__(config.port, config.baud, servo_map, log)
        self.config = config
        self.limits = firmware_limits(profile, servo_map)
        self.version: replies.Version | None = None
        self.channels = proto.MAX_CHANNELS
        self.seq = 0
        self.configured = False
        self.output_fault = False
        self.board_resets = 0
        self.clamped = 0
        self.nacks: collections.Counter[str] = collections.Counter()
        self._decoder = replies.ReplyDecoder()
        self._waiters: dict[object, asyncio.Future[replies.Reply]] = {}
        self._quiet: asyncio.TimerHandle | None = None
        self._answers = AnswerClock()
        self._repair: asyncio.Task[None] | None = None
        self._logged: set[str] = set()

    # -- the seam ------------------------------------------------------------------------------

    async def neutral(self, positions: Mapping[str, float]) -> None:
        """NEUTRAL: the firmware's neutral is the profile's (sent with the limits)."""
        self.pose = self.map.pose(positions, self.pose)
        if self.link.connected:
            self.link.write(proto.neutral(self._next_seq()))
            self._answers.sent()

    async def close(self) -> None:
        if self._repair is not None:
            self._repair.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._repair
        if self._quiet is not None:
            self._quiet.cancel()
        await super().close()

    def state(self) -> str:
        parts = [super().state()]
        if self.output_fault:
            parts.append("PCA9685 not answering")
        if self.board_resets:
            parts.append(f"board reset {self.board_resets}x")
        if self.nacks:
            parts.append("refused " + ", ".join(f"{k} {v}" for k, v in sorted(self.nacks.items())))
        return "; ".join(parts)

    async def device_status(self) -> dict[str, Any]:
        """VERSION and STATUS: firmware, channels, output, counters since boot, flags."""
        self._require_connection()
        assert self.version is not None
        status = await self._query_status()
        fields = {
            name: getattr(status, name)
            for name in status.__dataclass_fields__
            if name not in ("seq", "flags")
        }
        v = self.version
        return {
            "port": self.link.port,
            "firmware": f"{v.major}.{v.minor}.{v.patch}",
            "protocol": v.protocol,
            "channels": v.channels,
            "output": v.output.name,
            **fields,
            "flags": _flag_names(status.flags),
        }

    # -- connecting ----------------------------------------------------------------------------

    async def _identify(self) -> None:
        self.configured = False
        self._decoder = replies.ReplyDecoder()
        self._fail_waiters()
        self._answers.answered()
        version = await self._ping()
        if version.protocol != proto.PROTOCOL_VERSION:
            raise DriverConfigError(
                f"{self.link.port}: the firmware speaks protocol {version.protocol}, this "
                f"facesynth speaks {proto.PROTOCOL_VERSION}: flash it with `facesynth firmware "
                "flash`"
            )
        self.map.check_channels(version.channels, f"firmware's {version.output.name} build")
        self.version = version
        self.channels = version.channels
        status = await self._query_status()
        self.seq = status.last_seq if status.flags & proto.Flags.SEQ_VALID else 0
        log.info(
            "%s: facesynth firmware %d.%d.%d, %d channels (%s)",
            self.link.port,
            version.major,
            version.minor,
            version.patch,
            version.channels,
            version.output.name,
        )

    async def _ping(self) -> replies.Version:
        """PING every 200 ms until VERSION comes back (pyserial drops what came before)."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + self.config.connect_timeout
        while True:
            try:
                reply = await self._request(proto.ping(0), "VERSION", PING_INTERVAL_S)
            except TimeoutError:
                if loop.time() >= deadline:
                    raise TimeoutError(
                        f"no answer to PING within {self.config.connect_timeout:g} s "
                        "(is the facesynth firmware on this board?)"
                    ) from None
                continue
            assert isinstance(reply, replies.Version)
            return reply

    async def _query_status(self) -> replies.Status:
        reply = await self._request(proto.status(self.seq), "STATUS", ACK_TIMEOUT_S)
        assert isinstance(reply, replies.Status)
        return reply

    async def _configure(self) -> None:
        """SET_WATCHDOG, then SET_LIMITS (16 entries per frame), each acknowledged."""
        ms = self.config.board_watchdog_ms
        await self._command(lambda seq: proto.set_watchdog(seq, ms), "SET_WATCHDOG")
        entries = sorted(self.limits.items())
        for i in range(0, len(entries), proto.MAX_CHANNELS):
            chunk = dict(entries[i : i + proto.MAX_CHANNELS])
            await self._command(functools.partial(limits_frame, limits=chunk), "SET_LIMITS")
        self.configured = True

    async def _command(self, frame: Callable[[int], bytes], name: str) -> replies.Ack:
        """Send a state-changing command and wait for its ACK (one resync on a stale SEQ)."""
        for attempt in range(2):
            seq = self._next_seq()
            reply = await self._request(frame(seq), ("REPLY", seq), ACK_TIMEOUT_S)
            if isinstance(reply, replies.Ack):
                return reply
            assert isinstance(reply, replies.Nack)
            if reply.error == proto.ErrorCode.STALE_SEQUENCE and attempt == 0:
                self.seq = (await self._query_status()).last_seq
                continue
            raise DriverConfigError(f"the firmware refused {name}: {reply.error.name}")
        raise DriverError(f"the firmware keeps refusing {name} as stale")

    async def _request(self, frame: bytes, key: object, timeout: float) -> replies.Reply:
        future: asyncio.Future[replies.Reply] = asyncio.get_running_loop().create_future()
        self._waiters[key] = future
        try:
            if not self.link.write(frame):
                raise DriverError("the port is closed")
            return await asyncio.wait_for(future, timeout)
        finally:
            if self._waiters.get(key) is future:
                del self._waiters[key]

    def _fail_waiters(self) -> None:
        for future in self._waiters.values():
            if not future.done():
                future.cancel()
        self._waiters.clear()

    def _next_seq(self) -> int:
        self.seq = (self.seq + 1) & 0xFFFF
        return self.seq

    # -- running -------------------------------------------------------------------------------

    def _write_pose(self, pose: Mapping[int, int]) -> None:
        if not self.configured:  # limits first: the pose follows when they are acknowledged
            return
        self.link.write(pose_frame(self._next_seq(), self.map.checked(pose), self.channels))
        if self._answers.silent_for() > REPLY_TIMEOUT_S:
            self.link.lost(f"no reply from the firmware for {REPLY_TIMEOUT_S:g} s")
        self._answers.sent()

    def _received(self, data: bytes) -> None:
        for reply in self._decoder.feed(data):
            self._handle(reply)
        self._arm_quiet_timer()

    def _arm_quiet_timer(self) -> None:
        if self._quiet is not None:
            self._quiet.cancel()
            self._quiet = None
        if self._decoder.frames.pending:
            self._quiet = asyncio.get_running_loop().call_later(QUIET_S, self._line_quiet)

    def _line_quiet(self) -> None:
        """50 ms of silence in the middle of a reply: drop its start and rescan."""
        self._quiet = None
        for reply in self._decoder.discard_partial():
            self._handle(reply)
        self._arm_quiet_timer()

    def _handle(self, reply: replies.Reply) -> None:
        self._answers.answered()
        if isinstance(reply, replies.Version):
            key: object = "VERSION"
        elif isinstance(reply, replies.Status):
            key = "STATUS"
        else:
            key = ("REPLY", reply.seq)
        future = self._waiters.get(key)
        if future is not None and not future.done():
            future.set_result(reply)
            return
        if isinstance(reply, replies.Ack):
            self._on_ack(reply)
        elif isinstance(reply, replies.Nack):
            self._on_nack(reply)

    def _on_ack(self, ack: replies.Ack) -> None:
        if ack.clamped:
            self.clamped += ack.clamped
            self._once(
                "clamped",
                "the firmware clamped %d position(s): its limits and the profile's disagree",
                ack.clamped,
            )
        fault = bool(ack.flags & proto.Flags.OUTPUT_FAULT)
        if fault != self.output_fault:
            self.output_fault = fault
            if fault:
                log.warning("%s: the PCA9685 does not answer (OUTPUT_FAULT)", self.link.port)
            else:
                log.info("%s: the PCA9685 answers again", self.link.port)
        positions = {proto.COMMANDS[n].code for n in ("SET_ALL", "SET_SOME", "NEUTRAL")}
        if self.configured and ack.cmd in positions and not ack.flags & proto.Flags.LIMITS_SET:
            # Positions wait until the limits are back (and the ACKs of frames already on
            # their way, which say the same, are not counted again).
            self.configured = False
            self.board_resets += 1
            log.warning("%s: the board has reset; sending its limits again", self.link.port)
            self._start_repair(self._reconfigure())

    def _on_nack(self, nack: replies.Nack) -> None:
        self.nacks[nack.error.name] += 1
        if nack.error == proto.ErrorCode.STALE_SEQUENCE:
            self._once("stale", "stale sequence number: resynchronising from STATUS")
            self._start_repair(self._resync())
        else:
            self._once(nack.error.name, "the firmware refused a command: %s", nack.error.name)

    def _start_repair(self, work: Coroutine[Any, Any, None]) -> None:
        if self._repair is not None and not self._repair.done():
            work.close()
            return
        self._repair = asyncio.get_running_loop().create_task(self._repairing(work))

    async def _repairing(self, work: Coroutine[Any, Any, None]) -> None:
        try:
            await work
        except (TimeoutError, DriverError) as exc:
            self.link.lost(f"no answer while repairing the link ({exc or 'timeout'})")

    async def _reconfigure(self) -> None:
        await self._configure()
        self._write_pose(self.pose)

    async def _resync(self) -> None:
        self.seq = (await self._query_status()).last_seq
        self._write_pose(self.pose)

    def _once(self, key: str, message: str, *args: object) -> None:
        if key not in self._logged:
            self._logged.add(key)
            log.warning("%s: " + message, self.link.port, *args)


def _flag_names(flags: proto.Flags) -> list[str]:
    return [flag.name or "" for flag in proto.Flags if flags & flag]
