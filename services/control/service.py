"""Control interface C, service shell: ``…/servo_commands`` → a servo driver.

:class:`~services.control.core.ControlCore` decides everything (checks, freshness, speed limits,
the watchdog's return to neutral, catching up, reports); this shell feeds it commands and the
clock's readings (``ctx.clock``), hands its moves to the driver and publishes each on
``…/servo_state`` (a command's as a counted publication; the controller's own moves with
``move`` naming which). The face starts at neutral; on shutdown it returns to neutral within the
servos' limits before the driver closes (at once, step by step, when motion is measured on
media time: a ``--fast`` replay to a file or a virtual face).

A command's capture is aged when it leaves the input queue and once more on the last line
before the driver's ``send`` (:meth:`ControlCore.hand_over`, with the clock read there): a
command over the limit by then is not executed, counted ``stale`` like the others, and the face
holds, then returns to neutral when the watchdog says so.
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import math
from collections.abc import Awaitable, Mapping

from facesynth.runtime import codec
from facesynth.runtime.bus.base import SubscriptionClosed
from facesynth.runtime.clock import Clock, wall_offset_ns
from facesynth.runtime.clock_host import clock_host
from facesynth.runtime.profiles import Profile
from facesynth.runtime.rig_view import RigView
from facesynth.runtime.service import ServiceContext
from facesynth.schemas.messages import ServoCommands
from facesynth.services.control.core import RAMP_RATE_HZ, Arrival, ControlCore, MotionTime, Move
from facesynth.services.control.drivers.base import ServoDriver, ServoReading
from facesynth.services.control.freshness import StaleCapture

__all__ = ["RAMP_RATE_HZ", "ControlService"]

log = logging.getLogger("facesynth.control")


class ControlService:
    """The C service: one profile, one driver; ``last_frame`` was applied last."""

    def __init__(
        self,
        profile: Profile,
        driver: ServoDriver,
        *,
        watchdog_s: float = 0.5,
        queue: int = 8,
        motion_time: MotionTime = "real",
    ) -> None:
        self.host = clock_host()
        self.core = ControlCore(
            profile, watchdog_s=watchdog_s, motion_time=motion_time, own_host=self.host
        )
        self.driver = driver
        self.queue = queue
        self.last_frame = -1
        #: Sends the driver failed (logged, never raised: the service keeps running).
        self.driver_errors = 0
        self._states = itertools.count(1)

    async def serve(self, ctx: ServiceContext) -> None:
        """Drive the servos until cancelled."""
        clock = ctx.clock
        self.driver.observe(RigView(ctx.bus, ctx.rig))
        async with self.driver:
            await self._apply(ctx, self.core.start(clock.monotonic_ns()))
            try:
                await self._serve_commands(ctx, clock)
            finally:
                await self._stop(ctx, clock)

    async def _serve_commands(self, ctx: ServiceContext, clock: Clock) -> None:
        # Decoded and checked against the profile on arrival: commands for another profile or
        # for servos it does not have never take a place in the queue.
        subscription = ctx.subscribe(
            "servo_commands", self.queue, ServoCommands, check=self.core.check
        )
        ctx.ready()
        ctx.log.info(
            "control interface on %s (profile %s, %s, speed limits on %s time)",
            ctx.key("servo_commands"),
            self.core.profile.name,
            type(self.driver).__name__,
            self.core.motion_time,
        )
        while True:
            ctx.stats.note = self.driver.state()
            now = clock.monotonic_ns()
            due = self.core.due_ns()
            if now >= due:  # before any input: a flood never holds up the watchdog
                move = self.core.tick(now)
                if move is not None:
                    await self._apply(ctx, move)
                continue
            try:
                sample = await clock.wait_for(subscription.receive(), (due - now) / 1e9)
            except TimeoutError:
                continue
            except SubscriptionClosed:
                return
            ctx.stats.received += 1
            try:
                commands = sample.message or codec.decode(sample.payload, ServoCommands)
                arrival = Arrival(sample.t_received_ns, clock.monotonic_ns(), clock.time_ns())
                move, verdict = self.core.command(commands, arrival)
            except StaleCapture as exc:  # an upstream stall: hold, then neutral (the watchdog)
                ctx.stats.stale += 1
                if exc.note:  # once per run of them, not per command
                    ctx.log.warning("%s", exc.note)
                continue
            except ValueError as exc:
                ctx.reject(f"{sample.key}: {exc}")
                continue
            if verdict.note:
                ctx.log.warning("%s", verdict.note)
            try:
                await self._apply(ctx, move)
            except StaleCapture as exc:  # too old by its turn at the driver: withdrawn
                ctx.stats.stale += 1
                if exc.note:
                    ctx.log.warning("%s", exc.note)
                continue
            self.last_frame = max(self.last_frame, commands.seq)

    async def _stop(self, ctx: ServiceContext, clock: Clock) -> None:
        """Return to neutral within the limits (bounded in time), then let the driver close."""
        core = self.core
        now = clock.monotonic_ns()
        core.stop(now)
        deadline = now + round(core.stop_budget_s() * 1e9)
        virtual = core.motion_time == "media"  # nothing physical waits for the steps
        while not core.stopped and now <= deadline:
            due = core.due_ns()
            if virtual:
                now = max(now, due)
            else:
                await clock.sleep((due - now) / 1e9)
                now = clock.monotonic_ns()
            move = core.tick(now)
            if move is not None:
                with contextlib.suppress(Exception):  # the bus may be closing: moves go on
                    await self._apply(ctx, move)
        if not core.stopped:
            budget = core.stop_budget_s()
            log.warning("shutdown: the face did not reach neutral within %.2f s", budget)

    async def _apply(self, ctx: ServiceContext, move: Move) -> None:
        """Send a move to the driver and report it on ``…/servo_state``; a command too old by
        now raises :class:`StaleCapture` before the driver sees it."""
        if move.send:
            at_neutral = move.positions == self.core.neutral_positions
            if move.kind == "start" or (move.kind == "stop" and at_neutral):
                await self._guarded(self.driver.neutral(move.positions))
            else:
                # The wall-clock instant of the step (not of this call, which may come later),
                # by an offset a pause between two clock readings cannot skew.
                offset = wall_offset_ns(ctx.clock)
                info = move.info.at(move.t_ns + offset)
                if move.command:  # the last moment before the write: is it still young?
                    self.core.hand_over(move, ctx.clock.time_ns())
                await self._guarded(self.driver.send(move.positions, info))
        last = self.core.last_command
        readings = self._readings()
        state = ServoCommands(
            seq=last.seq if last is not None else 0,
            t_capture_ns=last.t_capture_ns if last is not None else 0,
            t_media_ns=last.t_media_ns if last is not None else 0,
            face=move.info.face,
            profile=self.core.profile.name,
            positions=move.positions,
            sender=ctx.instance,
            sender_seq=next(self._states),
            sent_ns=ctx.clock.time_ns(),
            sender_host=self.host,
            move=move.kind,
            measured={name: r.position_us for name, r in readings.items()},
            loads={n: r.load for n, r in readings.items() if r.load is not None},
            temperatures_c={
                n: r.temperature_c for n, r in readings.items() if r.temperature_c is not None
            },
            faults={name: r.fault for name, r in readings.items() if r.fault},
        )
        if move.command:
            ctx.publish("servo_state", state)
        else:  # the controller's own move: not a command applied, so not counted as one
            ctx.bus.publish_message(ctx.key("servo_state"), state, codec.encode)

    def _readings(self) -> Mapping[str, ServoReading]:
        """What the driver last read back from the servos (never waits on the device); a
        reading that is not a finite number is left out rather than published."""
        try:
            readings = self.driver.readings()
        except Exception as exc:  # a driver bug must not stop the face's controller
            self.driver_errors += 1
            log.warning("driver error reading the servos back: %s", exc)
            return {}
        return {name: r for name, r in readings.items() if _plausible(r)}

    async def _guarded(self, call: Awaitable[None]) -> None:
        try:
            await call
        except Exception as exc:  # a driver error must not stop the face's controller
            self.driver_errors += 1
            if self.driver_errors <= 10 or self.driver_errors % 100 == 0:
                log.warning("driver error (%d so far): %s", self.driver_errors, exc)


def _plausible(reading: ServoReading) -> bool:
    """Whether a reading's numbers are finite (None: not reported) and its fault one line."""
    numbers = (reading.position_us, reading.load, reading.temperature_c)
    finite = all(value is None or math.isfinite(value) for value in numbers)
    return finite and "\n" not in reading.fault
