"""The ``replay`` service: a recording back on a rig's keys, with its timing or as fast as
the chain takes it.

One stage is replayed (``--from``): by default the earliest one recorded (frames when there
are frames), so the stages after it run live on the recorded input. A multi-robot rig's
commands are replayed on their own robots' keys of the replay's rig (``--from servo_commands``
takes the rig's ``…/servo_commands`` and every ``…/servo_commands/<robot>``, the robot named
as recorded), so each robot's control interface takes its own. The payloads published
are the recorded ones, byte for byte, but for the ``capture_host`` of a live capture, which is
cleared: a recording's capture stamps are no live clock, so the stages and the control interface
do not age them from capture (a replay at another speed, or ``fast``, would look stale).
``restamp`` sets each capture time to the replay's clock instead, so latencies read as live;
then this host is the capture host (none with ``fast``, whose messages wait for credit).

Timing: message ``n`` is due at ``start + (log_time(n) - log_time(0)) / speed``, the sensor's
pacer on the recording's receipt clock. ``fast`` ignores the clock and keeps at most ``window``
messages in flight ahead of the last servo command seen (``…/servo_state`` when a control
interface runs, else ``…/servo_commands``): nothing is lost, however slow the chain.

The router: ``published`` counts only the messages published while the session had its router
(a message published with no router reaches nobody; the bus's :class:`RouterLink` says when);
:class:`ReplayLinkTally` keeps that count and says, in one line, how a lost router cut the
replay short.
"""

from __future__ import annotations

import asyncio
import time
from dataclasses import dataclass, field

import msgspec

from facesynth.app.recording import REPLAYABLE
from facesynth.app.recording.layout import message_type
from facesynth.app.recording.reader import Recording
from facesynth.runtime import codec, keys
from facesynth.runtime.bus.link import LinkFigures
from facesynth.runtime.clock_host import clock_host
from facesynth.runtime.service import ServiceContext
from facesynth.runtime.tasks import stop_tasks
from facesynth.schemas.messages import ServoCommands
from facesynth.services.sensor.core import Pacer
from facesynth.services.sensor.credit import CreditGate, ack_stage
from facesynth.services.sensor.service import wait_for_services


class ReplayOptionError(ValueError):
    """Replay options that do not fit the recording."""


class ReplayLinkError(ValueError):
    """The replay lost its router: some messages reached nobody (the line says how many)."""


@dataclass
class ReplayLinkTally:
    """What a replay's link to its router did to its messages (pure: link figures in).

    A message counts as delivered when it is published while the session has a router, or on
    a session that never had one (a peer with no router: nothing to lose); one published after
    the router was lost, before it is back, reached nobody.
    """

    #: Messages published while linked (what ``published`` reports).
    delivered: int = 0
    #: Messages published with no router (lost).
    unlinked: int = 0
    #: Routers lost since the replay started.
    losses: int = 0
    #: Seconds into the replay at which the router was first found lost.
    lost_at_s: float | None = None
    _losses_at_start: int | None = None

    def start(self, link: LinkFigures | None) -> None:
        """The link as the replay starts (earlier losses are not this replay's)."""
        self._losses_at_start = link.losses if link is not None else 0

    def published(self, link: LinkFigures | None, elapsed_s: float) -> bool:
        """Count one message published with ``link`` as it was; True when it was delivered."""
        self.observe(link, elapsed_s)
        if link is None or link.connected or link.losses == 0:
            self.delivered += 1
            return True
        self.unlinked += 1
        return False

    def observe(self, link: LinkFigures | None, elapsed_s: float) -> None:
        """Note the link's losses at ``elapsed_s`` seconds into the replay."""
        if link is None:
            return
        if self._losses_at_start is None:
            self._losses_at_start = link.losses
        losses = link.losses - self._losses_at_start
        if losses > self.losses:
            self.losses = losses
            if self.lost_at_s is None:
                self.lost_at_s = max(0.0, elapsed_s - link.down_for_s)

    def problem(self, total: int) -> str | None:
        """None when the router stayed, else the error line's text (``total``: messages sent)."""
        if not self.losses:
            return None
        at = f"{self.lost_at_s:.1f} s into the replay" if self.lost_at_s is not None else ""
        times = "" if self.losses == 1 else f" ({self.losses} times)"
        return (
            f"lost the Zenoh router {at}{times}: {self.delivered} of {total} messages were "
            f"published while linked, {self.unlinked} with no router reached nobody - "
            "is the router still running? (replay again once it is back)"
        )


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
    """Publishes one stage of a recording on ``ctx``'s rig; ``published`` counts the messages
    published while linked to the router, ``link`` how the router fared."""

    def __init__(self, recording: Recording, options: ReplayOptions) -> None:
        self.recording = recording
        self.options = options
        self.stage: keys.Stage = choose_stage(recording, options.stage)  # type: ignore[assignment]
        #: The recorded keys replayed: the stage's, each robot's too (``…/servo_commands/a``).
        self.sources = recording.stage_keys(self.stage)
        self.sent = 0
        self.link = ReplayLinkTally()
        self.last_seq = -1
        self.credit = CreditGate(options.window, options.ack_timeout, "message")
        self._sent = 0

    @property
    def published(self) -> int:
        """Messages published while linked to the router (all of them when it stayed)."""
        return self.link.delivered

    @property
    def stalls(self) -> int:
        """How often ``--fast`` went on without hearing from the end of the chain."""
        return self.credit.stalls

    async def _ack_stage(self, ctx: ServiceContext) -> keys.Stage:
        if self.stage == "servo_commands":
            return "servo_state"
        return await ack_stage(ctx)

    def targets(self, ctx: ServiceContext) -> dict[str, str]:
        """The key each recorded key is published on: the stage's key of ``ctx``'s rig, or, for
        a robot's key, that robot's key of ``ctx``'s rig."""
        targets = {}
        for source in self.sources:
            robot = keys.robot_of(source)
            targets[source] = (
                keys.stage_key(ctx.rig, self.stage, robot) if robot else ctx.key(self.stage)
            )
        return targets

    def _restamp(self, payload: bytes) -> bytes:
        cls = message_type(self.sources[0])
        try:
            message = msgspec.msgpack.decode(payload, type=cls)
        except (msgspec.DecodeError, msgspec.ValidationError):
            return payload
        host = "" if self.options.fast else clock_host()
        return codec.encode(
            msgspec.structs.replace(message, t_capture_ns=time.time_ns(), capture_host=host)
        )

    def _unlive(self, payload: bytes) -> bytes:
        """The recorded payload, without the capture host of a live capture (see the module
        doc); byte for byte when it names none."""
        if b"capture_host" not in payload:  # recorded before capture hosts
            return payload
        cls = message_type(self.sources[0])
        try:
            message = msgspec.msgpack.decode(payload, type=cls)
        except (msgspec.DecodeError, msgspec.ValidationError):
            return payload
        if not getattr(message, "capture_host", ""):
            return payload
        return codec.encode(msgspec.structs.replace(message, capture_host=""))

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
                sender_host=clock_host(),
            )
        )

    async def serve(self, ctx: ServiceContext) -> int:
        """Publish the stage's messages; return how many were published."""
        options = self.options
        ctx.ready()
        await wait_for_services(ctx, options.wait_for, options.wait_timeout)
        targets = self.targets(ctx)
        ack_task = None
        if options.fast:
            ack_stage = await self._ack_stage(ctx)
            ctx.log.info("--fast: at most %d messages ahead of %s", options.window, ack_stage)
            ack_task = asyncio.create_task(self.credit.watch(ctx, ack_stage))
        pacer = Pacer()
        started = time.monotonic()
        self.link.start(ctx.bus.link())
        first_log: int | None = None
        ctx.log.info(
            "replaying %s (%d messages) of %s on %s",
            self.stage,
            sum(map(self.recording.count, self.sources)),
            self.recording.path,
            ", ".join(sorted(set(targets.values()))),
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
                if options.restamp:
                    payload = self._restamp(item.payload)
                else:
                    payload = self._unlive(item.payload)
                if self.stage == "servo_commands":
                    payload = self._send_as_sender(payload, ctx)
                ctx.stats.received += 1
                ctx.bus.publish(targets[item.key], payload)
                self.sent += 1
                if self.link.published(ctx.bus.link(), time.monotonic() - started):
                    ctx.stats.record_published(0)  # the stats count what reached the router
                if seq is not None:
                    self.last_seq = max(self.last_seq, seq)
                await asyncio.sleep(0)
            if options.fast and self.last_seq >= 0:
                await self.credit.wait(ctx, self.last_seq + self.credit.flow.window)
        finally:
            self.link.observe(ctx.bus.link(), time.monotonic() - started)
            if ack_task is not None:
                await stop_tasks([ack_task])
        return self.published
