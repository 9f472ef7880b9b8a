"""Control interface C, service shell: ``…/servo_commands`` → a servo driver.

What was applied (after the checks and clamping) is published on ``…/servo_state``.

The face starts at neutral, every command is checked and clamped by :class:`ControlCore`, and
when commands stop for ``watchdog_s`` seconds the face returns to neutral, ramped over the
profile's ``neutral_ramp_s`` (new commands interrupt the ramp). On shutdown the face
is put back to neutral before the driver closes.
"""

from __future__ import annotations

import asyncio
import contextlib
import time

from facesynth.runtime import codec
from facesynth.runtime.bus.base import SubscriptionClosed
from facesynth.runtime.profiles import Profile
from facesynth.runtime.rig_view import RigView
from facesynth.runtime.service import ServiceContext
from schemas.messages import ServoCommands
from services.control.core import CommandInfo, ControlCore, Watchdog
from services.control.drivers.base import ServoDriver

#: Steps per second of a return to neutral.
RAMP_RATE_HZ = 25


class ControlService:
    """The C service; ``last_frame`` tells how far the chain has come."""

    def __init__(
        self, profile: Profile, driver: ServoDriver, *, watchdog_s: float = 0.5, queue: int = 8
    ) -> None:
        self.core = ControlCore(profile)
        self.driver = driver
        self.watchdog = Watchdog(watchdog_s)
        self.queue = queue
        self.last_frame = -1
        self.progress = asyncio.Event()
        #: Seconds to return to neutral when commands stop (the profile's ``neutral_ramp_s``).
        self.ramp_s = max(0.0, profile.neutral_ramp_s)

    async def serve(self, ctx: ServiceContext) -> None:
        """Drive the servos until cancelled."""
        self.driver.observe(RigView(ctx.bus, ctx.rig))
        await self.driver.connect()
        try:
            await self.driver.neutral(self.core.neutral())
            subscription = ctx.subscribe("servo_commands", self.queue)
            ctx.ready()
            ctx.log.info(
                "control interface on %s (profile %s, %s)",
                ctx.key("servo_commands"),
                self.core.profile.name,
                type(self.driver).__name__,
            )
            tick = min(0.1, self.watchdog.timeout_ns / 4e9)
            ramp: asyncio.Task[None] | None = None
            try:
                while True:
                    try:
                        # asyncio.timeout, not wait_for: on Python 3.11 wait_for can swallow a
                        # cancellation that races with a sample, and the service never stops.
                        async with asyncio.timeout(tick):
                            sample = await subscription.receive()
                    except TimeoutError:
                        if self.watchdog.expired(time.time_ns()):
                            ctx.log.info(
                                "no commands for %.2f s: face to neutral over %.2f s",
                                self.watchdog.timeout_ns / 1e9,
                                self.ramp_s,
                            )
                            ramp = asyncio.create_task(self._ramp_to_neutral())
                        continue
                    except SubscriptionClosed:
                        return
                    ctx.stats.received += 1
                    try:
                        commands = codec.decode(sample.payload, ServoCommands)
                        positions = self.core.accept(commands)
                    except ValueError as exc:
                        ctx.reject(f"{sample.key}: {exc}")
                        continue
                    await _cancel(ramp)  # commands are back: they take over
                    ramp = None
                    info = CommandInfo(commands.seq, commands.t_capture_ns, commands.face)
                    await self.driver.send(positions, info)
                    self.watchdog.feed(time.time_ns())
                    applied = ServoCommands(
                        seq=commands.seq,
                        t_capture_ns=commands.t_capture_ns,
                        t_media_ns=commands.t_media_ns,
                        face=commands.face,
                        profile=commands.profile,
                        positions=positions,
                    )
                    ctx.publish("servo_state", applied)
                    self.last_frame = max(self.last_frame, commands.seq)
                    self.progress.set()
            finally:
                await _cancel(ramp)
        finally:
            try:
                await self.driver.neutral(self.core.neutral())
            finally:
                await self.driver.close()

    async def _ramp_to_neutral(self) -> None:
        """Move to neutral in even steps over ``ramp_s`` (at once when it is 0)."""
        steps = max(1, round(self.ramp_s * RAMP_RATE_HZ))
        for positions in self.core.ramp_to_neutral(steps):
            await self.driver.send(
                positions, CommandInfo(frame=None, t_capture_ns=None, face=False)
            )
            self.core.mark_sent(positions)
            if steps > 1:
                await asyncio.sleep(self.ramp_s / steps)


async def _cancel(task: asyncio.Task[None] | None) -> None:
    """Cancel a return to neutral that is still running."""
    if task is not None and not task.done():
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task
