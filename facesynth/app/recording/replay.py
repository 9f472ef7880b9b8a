"""The ``replay`` service: a recording back on a rig's keys, with its timing or as fast as
the chain takes it.

One stage is replayed (``--from``): by default the earliest one recorded (frames when there
are frames), so the stages after it run live on the recorded input. The payloads published
are the recorded ones, byte for byte (``restamp`` sets each capture time to the replay's clock
instead, so latencies read as live).

Timing: message ``n`` is due at ``start + (log_time(n) - log_time(0)) / speed``, the sensor's
pacer on the recording's receipt clock. ``fast`` ignores the clock and keeps at most ``window``
messages in flight ahead of the last servo command seen (``…/servo_state`` when a control
interface runs, else ``…/servo_commands``): nothing is lost, however slow the chain.
"""

from __future__ import annotations

import asyncio
import contextlib
import socket
import time
from dataclasses import dataclass, field

import msgspec

from facesynth.app.recording import REPLAYABLE
from facesynth.app.recording.layout import key_kind, message_type
from facesynth.app.recording.reader import Recording
from facesynth.runtime import codec, keys
from facesynth.runtime.service import ServiceContext
from schemas.messages import ServoCommands
from services.sensor.core import Pacer
from services.sensor.credit import CreditGate, ack_stage
from services.sensor.service import wait_for_services


class ReplayOptionError(ValueError):
    """Replay options that do not fit the recording."""


class _Seq(msgspec.Struct):
    seq: int


_SEQ = msgspec.msgpack.Decoder(_Seq)


def payload_seq(payload: bytes) -> int | None:
    """The ``seq`` of a message payload, or ``None`` when it has none (garbage, stats)."""
    try:
        return _SEQ.decode(payload).seq
    except (msgspec.DecodeError, msgspec.ValidationError):
        return None


@dataclass
class ReplayOptions:
    """How to replay."""

    stage: str | None = None
    speed: float = 1.0
    fast: bool = False
    window: int = 2
    ack_timeout: float = 2.0
    restamp: bool = False
    wait_for: list[str] = field(default_factory=list)
    wait_timeout: float = 10.0

    def __post_init__(self) -> None:
        if self.stage is not None and self.stage not in REPLAYABLE:
            raise ReplayOptionError(f"--from must be one of {', '.join(REPLAYABLE)}")
        if not (self.speed > 0 and self.speed < 1e6):
            raise ReplayOptionError("--speed must be a positive factor, e.g. 0.5 or 2")
        if self.window < 1:
            raise ReplayOptionError("--window must be at least 1")


def choose_stage(recording: Recording, stage: str | None) -> str:
    """The stage to replay: ``stage`` if recorded, else the earliest replayable one recorded."""
    recorded = [s for s in recording.stages() if s in REPLAYABLE]
    if stage is not None:
        if stage not in recorded:
            raise ReplayOptionError(
                f"{recording.path} holds no {stage} messages "
                f"(it has: {', '.join(recording.stages()) or 'none'})"
            )
        return stage
    if not recorded:
        raise ReplayOptionError(
            f"{recording.path} holds nothing to replay (no {', '.join(REPLAYABLE)} messages)"
        )
    return recorded[0]


class Replayer:
    """Publishes one stage of a recording on ``ctx``'s rig; ``published`` counts messages."""

    def __init__(self, recording: Recording, options: ReplayOptions) -> None:
        self.recording = recording
        self.options = options
        self.stage: keys.Stage = choose_stage(recording, options.stage)  # type: ignore[assignment]
        self.sources = [key for key in recording.bus_keys() if key_kind(key) == self.stage]
        self.published = 0
        self.last_seq = -1
        self.credit = CreditGate(options.window, options.ack_timeout, "message")
        self._sent = 0

    @property
    def stalls(self) -> int:
        """How often ``--fast`` went on without hearing from the end of the chain."""
        return self.credit.stalls

    async def _ack_stage(self, ctx: ServiceContext) -> keys.Stage:
        if self.stage == "servo_commands":
            return "servo_state"
        return await ack_stage(ctx)

    def _restamp(self, payload: bytes) -> bytes:
        cls = message_type(self.sources[0])
        try:
            message = msgspec.msgpack.decode(payload, type=cls)
        except (msgspec.DecodeError, msgspec.ValidationError):
            return payload
        return codec.encode(msgspec.structs.replace(message, t_capture_ns=time.time_ns()))

    def _send_as_sender(self, payload: bytes, ctx: ServiceContext) -> bytes:
        """A replayed servo command, stamped as sent now by this replay (the controller drops
        commands older than its profile allows, and a recorded one is as old as the recording)."""
        try:
            message = msgspec.msgpack.decode(payload, type=ServoCommands)
        except (msgspec.DecodeError, msgspec.ValidationError):
            return payload
        self._sent += 1
        return codec.encode(
            msgspec.structs.replace(
                message,
                sender=f"{ctx.instance}/replay",
                sender_seq=self._sent,
                sent_ns=time.time_ns(),
                sender_host=socket.gethostname(),
            )
        )

    async def serve(self, ctx: ServiceContext) -> int:
        """Publish the stage's messages; return how many were published."""
        options = self.options
        ctx.ready()
        await wait_for_services(ctx, options.wait_for, options.wait_timeout)
        target = ctx.key(self.stage)
        ack_task = None
        if options.fast:
            ack_stage = await self._ack_stage(ctx)
            ctx.log.info("--fast: at most %d messages ahead of %s", options.window, ack_stage)
            ack_task = asyncio.create_task(self.credit.watch(ctx, ack_stage))
        pacer = Pacer()
        first_log: int | None = None
        ctx.log.info(
            "replaying %s (%d messages) of %s on %s",
            self.stage,
            sum(map(self.recording.count, self.sources)),
            self.recording.path,
            target,
        )
        try:
            for item in self.recording.payloads(self.sources):
                seq = payload_seq(item.payload)
                if options.fast:
                    if seq is not None:
                        await self.credit.wait(ctx, seq)
                else:
                    first_log = item.log_time if first_log is None else first_log
                    offset = round((item.log_time - first_log) / options.speed)
                    delay = pacer.delay_ns(offset, time.monotonic_ns())
                    if delay:
                        await asyncio.sleep(delay / 1e9)
                payload = self._restamp(item.payload) if options.restamp else item.payload
                if self.stage == "servo_commands":
                    payload = self._send_as_sender(payload, ctx)
                ctx.stats.received += 1
                ctx.bus.publish(target, payload)
                ctx.stats.record_published(0)
                self.published += 1
                if seq is not None:
                    self.last_seq = max(self.last_seq, seq)
                await asyncio.sleep(0)
            if options.fast and self.last_seq >= 0:
                await self.credit.wait(ctx, self.last_seq + self.credit.flow.window)
        finally:
            if ack_task is not None:
                ack_task.cancel()
                with contextlib.suppress(asyncio.CancelledError):
                    await ack_task
        return self.published
