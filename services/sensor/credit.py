"""``--fast`` flow control: send at most a window ahead of what the end of the chain applied.

Shared by the sensor and by ``facesynth replay``: both send as fast as the chain takes their
messages, and hear back from the last stage running (each robot's control interface on
``…/servo_state/<robot>``, or, with none running, its translator on ``…/servo_commands/…``).
The slowest robot still answering gives the credit (:class:`~services.sensor.core.SlowestCredit`);
after ``ack_timeout`` without an answer the sender goes on, once per window, and counts a stall.
"""

from __future__ import annotations

import asyncio
import contextlib

from facesynth.runtime import codec, keys, limits
from facesynth.runtime.service import ServiceContext
from facesynth.schemas.messages import ServoCommands
from facesynth.services.sensor.core import FlowWindow, SlowestCredit


def _decode_ack(payload: bytes) -> ServoCommands:
    return codec.decode(payload, ServoCommands)


def _take_ack(message: object) -> ServoCommands:
    return codec.check(message, ServoCommands)


async def ack_stage(ctx: ServiceContext) -> keys.Stage:
    """Where the credit comes from: ``servo_state`` while a control interface of the rig is
    alive, else ``servo_commands``."""
    alive = await ctx.bus.alive(keys.health_pattern(ctx.rig), timeout=0.5)
    control = any(p is not None and p[1] == "control" for p in map(keys.parse_service_key, alive))
    return "servo_state" if control else "servo_commands"


class CreditGate:
    """The credit window of one sender; ``what`` names its messages in the log ("frame")."""

    def __init__(self, window: int, ack_timeout: float, what: str) -> None:
        self.flow = FlowWindow(window)
        self.ack_timeout = ack_timeout
        self.what = what
        #: How often the sender went on without an answer.
        self.stalls = 0
        self._acked = asyncio.Event()

    async def watch(self, ctx: ServiceContext, stage: keys.Stage) -> None:
        """Follow every robot's answers on ``stage`` until cancelled."""
        # Acks are not data: a full mailbox only drops old ones, so they stay out of the stats.
        subscription = ctx.bus.subscribe_queued(keys.robots_pattern(ctx.rig, stage), 64)
        # Screened on arrival: a flood of bad messages never takes an ack's place.
        subscription.guard(limits.stage_limit(stage), _decode_ack, take=_take_ack)
        credit = SlowestCredit(round(self.ack_timeout * 1e9))
        try:
            async for sample in subscription:
                state = sample.message
                if state.move != "command":  # the controller moving on its own acknowledges nothing
                    continue
                robot = keys.robot_of(sample.key) or ""
                self.flow.acked = credit.heard(robot, state.seq, ctx.clock.monotonic_ns())
                self._acked.set()
        finally:
            subscription.close()

    async def wait(self, ctx: ServiceContext, seq: int) -> None:
        """Return once message ``seq`` may go (or ``ack_timeout`` passed without an answer)."""
        clock = ctx.clock
        deadline = clock.monotonic_ns() + round(self.ack_timeout * 1e9)
        while not self.flow.may_send(seq):
            self._acked.clear()
            remaining = (deadline - clock.monotonic_ns()) / 1e9
            if remaining <= 0:
                self.stalls += 1
                ctx.log.warning(
                    "no servo command for %s %d after %.1f s: sending on",
                    self.what,
                    seq - self.flow.window,
                    self.ack_timeout,
                )
                self.flow.ack(seq - self.flow.window)
                return
            with contextlib.suppress(TimeoutError):
                await clock.wait_for(self._acked.wait(), remaining)
