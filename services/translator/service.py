"""Translator T, service shell: ``…/features`` → ``…/servo_commands``.

Before its first command, and again once the control interface has moved on its own (it
started, returned to neutral after commands stopped reaching it, stopped, or reports being idle:
anything but following commands), the translator learns where the servos are from
``…/servo_state`` and resumes from there (:meth:`Translator.resume`), so its next command never
asks for a jump. With no report yet it starts from neutral, where a controller starts, and an
idle controller reports where it is every half second, which the translator then takes. While
the controller follows its commands (or catches up with them within the speed limits) it is
where this translator left it, so a pause in the input alone changes nothing. (It never waits
for a report: a real-time stream would lose frames meanwhile. Until it has one, the
controller's own speed limits keep any difference from becoming a jump.)

Every command is stamped for the controller's freshness checks: ``sender`` (this instance and
a token of this start), ``sender_seq``, ``sent_ns`` (wall clock) and ``sender_host``.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import secrets
import socket
import traceback

import msgspec

from facesynth.runtime import codec, limits
from facesynth.runtime.bus.base import Subscription
from facesynth.runtime.service import ServiceContext
from schemas.messages import Features, ServoCommands
from services.translator.core import Translator

#: Moves on ``…/servo_state`` during which the controller follows a sender's commands.
FOLLOWING = ("command", "catch-up")


class ServoStateWatch:
    """The newest positions the control interface reported for one profile, and whether it
    moved on its own since :meth:`take` was last called."""

    def __init__(self, profile: str) -> None:
        self.profile = profile
        self.positions: dict[str, float] | None = None
        self.moved_on_its_own = False

    def see(self, state: ServoCommands) -> None:
        """One ``…/servo_state`` message (another profile's is ignored)."""
        if state.profile != self.profile:
            return
        self.positions = dict(state.positions)
        if state.move not in FOLLOWING:
            self.moved_on_its_own = True

    def take(self) -> dict[str, float] | None:
        """The positions to resume from (``None``: never reported); clears ``moved_on_its_own``."""
        self.moved_on_its_own = False
        return self.positions

    async def follow(self, subscription: Subscription) -> None:
        """Keep up with the reports until the subscription closes (screened on arrival)."""
        async for sample in subscription:
            if sample.message is not None:
                self.see(sample.message)


def _decode_state(payload: bytes) -> ServoCommands:
    return codec.decode(payload, ServoCommands)


async def serve_translator(
    ctx: ServiceContext,
    translator: Translator,
    queue: int = 8,
) -> None:
    """Translate every Features message until cancelled."""
    clock = ctx.clock
    watch = ServoStateWatch(translator.profile.name)
    # Newest report only; an overwritten report is no data lost, so not in the service's stats.
    states = ctx.bus.subscribe_latest(ctx.key("servo_state"))
    states.guard(limits.stage_limit("servo_state"), _decode_state)
    follower = asyncio.create_task(watch.follow(states), name="servo-state-watch")
    subscription = ctx.subscribe("features", queue, Features)
    ctx.ready()
    ctx.log.info("translator on %s (profile %s)", ctx.key("features"), translator.profile.name)
    sender = f"{ctx.instance}/{secrets.token_hex(3)}"
    host = socket.gethostname()
    count = itertools.count(1)
    started = False
    try:
        async for sample in subscription:
            ctx.stats.received += 1
            try:
                features = sample.message or codec.decode(sample.payload, Features)
            except ValueError as exc:
                ctx.reject(f"{sample.key}: {exc}")
                continue
            if not started or watch.moved_on_its_own:
                positions = watch.take()
                where = positions if positions is not None else translator.neutral()
                if not started or not translator.is_at(where):
                    translator.resume(where)
                    ctx.log.info(
                        "resuming from the servos' %s positions",
                        "reported" if positions is not None else "neutral (no report yet)",
                    )
                started = True
            try:
                commands = translator.translate(features)
            except ValueError as exc:
                ctx.reject(f"{sample.key}: {exc}")
                continue
            except Exception:  # a bug must not stop the robot's face: count it, log it, go on
                ctx.reject(f"{sample.key}: internal error\n{traceback.format_exc()}")
                continue
            stamped = msgspec.structs.replace(
                commands,
                sender=sender,
                sender_seq=next(count),
                sent_ns=clock.time_ns(),
                sender_host=host,
            )
            ctx.publish("servo_commands", stamped)
    finally:
        states.close()
        follower.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await follower
