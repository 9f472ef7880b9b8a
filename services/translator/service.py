"""Translator T, service shell: ``…/features`` → ``…/servo_commands``.

The pure parts are :class:`~services.translator.core.Translator` (features → positions) and
:class:`~facesynth.services.translator.resume.ResumingTranslator` (where to resume from, after the
control interface's reports on ``…/servo_state``, and the stamps for its freshness checks).
"""

from __future__ import annotations

import asyncio
import secrets

from facesynth.runtime import codec, limits
from facesynth.runtime.clock_host import clock_host
from facesynth.runtime.service import ServiceContext, serve_transform
from facesynth.schemas.messages import Features, ServoCommands
from facesynth.services.translator.core import Translator
from facesynth.services.translator.resume import ResumingTranslator, ServoStateWatch
from facesynth.services.translator.robot_face import RobotFace, RobotFaceFeed

__all__ = ["RobotFace", "ServoStateWatch", "serve_translator"]

#: Controller reports kept between two frames (the oldest dropped beyond).
STATE_QUEUE = 64


def _decode_state(payload: bytes) -> ServoCommands:
    return codec.decode(payload, ServoCommands)


def _take_state(message: object) -> ServoCommands:
    return codec.check(message, ServoCommands)


async def serve_translator(
    ctx: ServiceContext, translator: Translator, queue: int = 8, robot: RobotFace | None = None
) -> None:
    """Translate every Features message until cancelled; with ``robot``, the loop closed
    through the robot's own face (:mod:`facesynth.services.translator.robot_face`)."""
    core = ResumingTranslator(
        translator, sender=f"{ctx.instance}/{secrets.token_hex(3)}", host=clock_host()
    )
    # Read just before each command, not as they come: a report costs no event-loop wake-up
    # (handing a message to the event loop costs 0.1-0.25 ms of CPU at 30 messages/s, measured
    # on loopback against the same subscriber taking it on Zenoh's thread). The
    # controller reports once per command, so a few wait between two frames; while no frames
    # come the oldest are dropped (the newest positions, and any move of the controller's own
    # among the newest, are what a resume needs). Not in the service's stats.
    states = ctx.bus.subscribe_queued(ctx.key("servo_state"), STATE_QUEUE)
    states.guard(limits.stage_limit("servo_state"), _decode_state, take=_take_state)
    states.poll_only()
    feed = keeper = None
    if robot is not None:
        feed = RobotFaceFeed(ctx, translator, translator.close_loop_once(), robot)
        keeper = asyncio.create_task(feed.keep())
        where = robot.key or "the robot's camera, tracked here"
        ctx.log.info("closed loop through the robot's face on %s", where)

    def transform(features: Features) -> ServoCommands:
        core.watch.catch_up(states)
        if feed is not None:
            feed.catch_up()
        commands = core.translate(features, ctx.clock.time_ns())
        if core.resumed:
            ctx.log.info("resuming from the servos' %s positions", core.resumed)
        return commands

    listening = f"translator on {ctx.key('features')} (profile {translator.profile.name})"
    try:
        await serve_transform(
            ctx,
            "features",
            Features,
            "servo_commands",
            transform,
            queue,
            listening,
            # Features captured longer ago than the controller would execute are not translated.
            max_age_s=translator.profile.max_command_age_s,
        )
    finally:
        states.close()
        if keeper is not None:
            keeper.cancel()
        if feed is not None:
            feed.close()
