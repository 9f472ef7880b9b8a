"""Control interface C, service shell: ``…/servo_commands`` → a servo driver.

What was applied (after the checks and clamping) is published on ``…/servo_state``.

The face starts at neutral, every command is checked and clamped by :class:`ControlCore`, and
when commands stop for ``watchdog_s`` seconds the face returns to neutral, ramped over the
profile's ``neutral_ramp_s`` (new commands interrupt the ramp): neutral is reached exactly
``watchdog_s + neutral_ramp_s`` after the last command. On shutdown the face is put back to
neutral before the driver closes. Time comes from the context's clock (``ctx.clock``).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Awaitable, Mapping

from facesynth.runtime import codec
from facesynth.runtime.bus.base import SubscriptionClosed
from facesynth.runtime.clock import Clock
from facesynth.runtime.profiles import Profile
from facesynth.runtime.rig_view import RigView
from facesynth.runtime.service import ServiceContext
from schemas.messages import ServoCommands
from services.control.core import CommandInfo, ControlCore, Watchdog
from services.control.drivers.base import ServoDriver

#: Steps per second of a return to neutral.
RAMP_RATE_HZ = 25

log = logging.getLogger("facesynth.control")


class ControlService:
    """The C service: one profile, one driver, a watchdog; ``last_frame`` was applied last."""

    def __init__(
        self, profile: Profile, driver: ServoDriver, *, watchdog_s: float = 0.5, queue: int = 8
    ) -> None:
        self.core = ControlCore(profile)
        self.driver = driver
        self.watchdog = Watchdog(watchdog_s)
        self.queue = queue
        self.last_frame = -1
        #: Seconds to return to neutral when commands stop (the profile's ``neutral_ramp_s``).
        self.ramp_s = max(0.0, profile.neutral_ramp_s)
        #: Sends the driver failed (logged, never raised: the service keeps running).
        self.driver_errors = 0

    async def serve(self, ctx: ServiceContext) -> None:
        """Drive the servos until cancelled."""
        clock = ctx.clock
        self.driver.observe(RigView(ctx.bus, ctx.rig))
        async with self.driver:
            try:
                await self._neutral()
                await self._serve_commands(ctx, clock)
            finally:
                await self._neutral()

    async def _serve_commands(self, ctx: ServiceContext, clock: Clock) -> None:
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
                ctx.stats.note = self.driver.state()
                try:
                    sample = await clock.wait_for(subscription.receive(), tick)
                except TimeoutError:
                    if self.watchdog.expired(clock.monotonic_ns()):
                        ctx.log.info(
                            "no commands for %.2f s: face to neutral over %.2f s",
                            self.watchdog.timeout_ns / 1e9,
                            self.ramp_s,
                        )
                        ramp = asyncio.create_task(self._ramp_to_neutral(clock))
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
                await self._send(positions, info)
                self.watchdog.feed(clock.monotonic_ns())
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
        finally:
            await _cancel(ramp)

    async def _ramp_to_neutral(self, clock: Clock) -> None:
        """Move to neutral in ``steps`` even steps, step ``i`` at ``i * ramp_s / steps``.

        Neutral is reached exactly ``ramp_s`` after the start (at once when it is 0); steps are
        timed from the start, so late wake-ups do not add up.
        """
        steps = max(1, round(self.ramp_s * RAMP_RATE_HZ))
        start_ns = clock.monotonic_ns()
        ramp_ns = round(self.ramp_s * 1e9)
        for step, positions in enumerate(self.core.ramp_to_neutral(steps), start=1):
            if ramp_ns > 0:
                due_ns = start_ns + ramp_ns * step // steps
                await clock.sleep((due_ns - clock.monotonic_ns()) / 1e9)
            await self._send(positions, CommandInfo(frame=None, t_capture_ns=None, face=False))
            self.core.mark_sent(positions)

    async def _send(self, positions: Mapping[str, float], info: CommandInfo) -> None:
        """Hand positions to the driver; its errors are counted and logged, never raised."""
        await self._guarded(self.driver.send(positions, info))

    async def _neutral(self) -> None:
        await self._guarded(self.driver.neutral(self.core.neutral()))

    async def _guarded(self, call: Awaitable[None]) -> None:
        try:
            await call
        except Exception as exc:  # a driver error must not stop the face's controller
            self.driver_errors += 1
            if self.driver_errors <= 10 or self.driver_errors % 100 == 0:
                log.warning("driver error (%d so far): %s", self.driver_errors, exc)


async def _cancel(task: asyncio.Task[None] | None) -> None:
    """Cancel a return to neutral that is still running."""
    if task is not None and not task.done():
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task
