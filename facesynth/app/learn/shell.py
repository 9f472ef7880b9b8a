"""The babbling run, asyncio shell: the robot's rig on one bus, the babbler, the recorder.

:func:`babble` runs, on one bus (``facesynth learn`` opens an embedded router, as ``facesynth
run`` does), the nodes a graph would: the robot's camera (sensor), the tracker (points), the
control interface with the servo driver, and, once the babbler has the robot held at neutral,
the features node, so that the neutral it learns is the robot's. The babbler
(:class:`~facesynth.app.learn.core.Babbler`) publishes stamped ``ServoCommands`` on the rig's
``…/servo_commands`` as the translator would (so the control interface's clamping, speed and
acceleration limits, freshness checks and watchdog all hold), reads ``…/servo_state`` and
``…/features``, and publishes every settled pose as a ``BabbleSample`` on ``…/babble`` (and,
while streaming, every frame with a face, as a sample of kind ``stream``); the
recorder (:mod:`facesynth.app.recording.recorder`) writes those, the features, the servo
streams and a frame now and then into the session file.

A first Ctrl-C (SIGINT or SIGTERM) ends babbling: the servos go back to neutral, the recorder
takes the last messages and the file is completed; a second one stops at once (the control
interface still returns to neutral as it shuts down).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import secrets
import signal
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any

from facesynth.app.chain import freeze_startup_objects, node_context
from facesynth.app.engine.router import embedded_bus
from facesynth.app.learn.core import Babbler, Sample
from facesynth.app.learn.progress import Progress
from facesynth.app.learn.session import SessionFile
from facesynth.app.learn.settle import StalledError
from facesynth.app.learn.stream import STREAM_KIND, StreamFrame
from facesynth.app.recording.recorder import Recorder, RecordOptions
from facesynth.app.servo_sender import ServoSender
from facesynth.app.wiring import StageParts
from facesynth.runtime import codec, keys
from facesynth.runtime.bus.base import Bus, Subscription
from facesynth.runtime.bus.zenoh_bus import ZenohOptions
from facesynth.runtime.service import ServiceContext, run_service
from facesynth.runtime.tasks import cancel_and_wait, stop_tasks
from facesynth.schemas.messages import BabbleSample, Features, ServoCommands

log = logging.getLogger("facesynth.learn")

#: How often the babbler steps and (re)sends its command: the control interface's watchdog
#: needs commands well within its 0.5 s.
RATE_HZ = 30.0
#: After this long at neutral without a face, say that the camera sees none (seconds).
NO_FACE_NOTICE_S = 10.0
#: What the session records besides ``babble``.
RECORD_KEYS = ["features", "servo_commands", "servo_state", "babble", "input"]


class LearnRunError(RuntimeError):
    """A run that could not go on (a node failed, the servos stalled); the message says why."""


@dataclass
class LearnResult:
    """What a babbling run did."""

    taken: int
    skipped: int
    next_pose: int
    seconds: float
    interrupted: bool
    recorded: int
    #: Poses taken by how the servos were known to be there: ``commanded`` (a fixed wait),
    #: ``measured`` (read back), ``measured timeout`` (read back, not there in time).
    reached: dict[str, int] = field(default_factory=dict)
    #: Frames taken while streaming (``--plan stream``).
    streamed: int = 0


class BabbleShell:
    """The babbler on the bus: steps the core ``RATE_HZ`` times a second."""

    def __init__(
        self,
        babbler: Babbler,
        *,
        seed: int,
        progress: Progress,
        on_neutral: Callable[[], None],
    ) -> None:
        self.babbler = babbler
        self.seed = seed
        self.progress = progress
        self.on_neutral = on_neutral
        self.commands = ServoSender()
        self.samples = 0
        #: Whether C's reports carry read-back positions (said once in the log).
        self.reading = False
        self._started_ns = 0

    async def serve(self, ctx: ServiceContext) -> None:
        """Babble until the core is done (its budget spent, or stopped)."""
        self.commands.sender = f"{ctx.instance}/{secrets.token_hex(3)}"
        clock = ctx.clock
        states = ctx.subscribe("servo_state", 1, ServoCommands)
        features = ctx.subscribe("features", 16, Features)
        ctx.ready()
        followers = [
            asyncio.create_task(self._follow_states(states, ctx)),
            asyncio.create_task(self._follow_features(features, ctx)),
        ]
        self._started_ns = clock.monotonic_ns()
        neutral_started: int | None = None
        warned = False
        try:
            while not self.babbler.done:
                now = clock.monotonic_ns()
                try:
                    step = self.babbler.step(now)
                except StalledError as exc:
                    raise LearnRunError(
                        f"{exc}: does the control interface run profile "
                        f"{self.babbler.profile.name!r}?"
                    ) from None
                if step.phase != "done":
                    self.commands.send(
                        ctx,
                        step.targets,
                        face=step.phase in ("babbling", "streaming"),
                        profile=self.babbler.profile.name,
                        started_ns=self._started_ns,
                    )
                if step.sample is not None:
                    self._publish(ctx, step.sample)
                for frame in step.frames:
                    self._publish_frame(ctx, frame)
                if self.babbler.at_neutral and neutral_started is None:
                    neutral_started = now
                    self.on_neutral()
                if (
                    neutral_started is not None
                    and not warned
                    and not self.babbler.face_seen
                    and now - neutral_started > NO_FACE_NOTICE_S * 1e9
                ):
                    warned = True
                    ctx.log.warning(
                        "no face in the camera's view after %.0f s at neutral: point the "
                        "camera at the robot's face (babbling starts once it sees it)",
                        NO_FACE_NOTICE_S,
                    )
                self.progress.update(step.phase, self.babbler.index, now / 1e9)
                await clock.sleep(1 / RATE_HZ)
        finally:
            await cancel_and_wait(followers)
            now_s = clock.monotonic_ns() / 1e9
            self.progress.update(self.babbler.phase, self.babbler.index, now_s, force=True)

    async def _follow_states(self, subscription: Subscription, ctx: ServiceContext) -> None:
        async for sample in subscription:
            state = sample.message
            if isinstance(state, ServoCommands) and state.profile == self.babbler.profile.name:
                if state.measured and not self.reading:
                    self.reading = True
                    settle = self.babbler.options.settle
                    ctx.log.info(
                        "the driver reads the servos back: poses settle on measured positions "
                        "(within %g us of the command, or %g s after C applied it), not on a "
                        "fixed wait",
                        settle.measured_tol_us,
                        settle.measured_timeout_s,
                    )
                self.babbler.servos(state.positions, ctx.clock.monotonic_ns(), state.measured)

    async def _follow_features(self, subscription: Subscription, ctx: ServiceContext) -> None:
        async for sample in subscription:
            ctx.stats.received += 1
            message = sample.message
            if isinstance(message, Features):
                # when the frame was taken, not when its features arrived (the tracker's latency
                # must not pass off a frame from before the servos got there as a settled one)
                now = ctx.clock.monotonic_ns()
                age = max(0, ctx.clock.time_ns() - message.t_capture_ns)
                self.babbler.features(
                    message.face, message.raw, message.neutral_ready, now - age, now
                )

    def _publish_frame(self, ctx: ServiceContext, frame: StreamFrame) -> None:
        """A streamed frame as a sample of kind ``stream``: taken at ``t_capture_ns`` (the
        wall clock), one frame, not settled, its commands those in force then."""
        clock = ctx.clock
        message = BabbleSample(
            seq=self.babbler.index,
            t_capture_ns=clock.time_ns() - max(0, clock.monotonic_ns() - frame.t_ns),
            t_media_ns=max(0, frame.t_ns - self._started_ns),
            profile=self.babbler.profile.name,
            kind=STREAM_KIND,
            commanded=frame.commanded,
            features=frame.features,
            frames=1,
            settled=False,
            seed=self.seed,
        )
        ctx.bus.publish(keys.stage_key(ctx.rig, "babble"), codec.encode(message))
        self.samples += 1

    def _publish(self, ctx: ServiceContext, sample: Sample) -> None:
        message = BabbleSample(
            seq=sample.pose.index,
            t_capture_ns=ctx.clock.time_ns(),
            t_media_ns=max(0, sample.t_ns - self._started_ns),
            profile=self.babbler.profile.name,
            kind=sample.pose.kind,
            commanded=sample.commanded,
            reported=sample.reported,
            features=sample.face.features,
            spread=sample.face.spread,
            frames=sample.face.frames,
            settled=sample.face.settled,
            seed=self.seed,
            measured=sample.measured,
            reached=sample.face.reached,
        )
        ctx.bus.publish(keys.stage_key(ctx.rig, "babble"), codec.encode(message))
        self.samples += 1


async def on_embedded_router(
    listen: list[str],
    zenoh: ZenohOptions,
    rig: str,
    run: Callable[[Bus], Awaitable[LearnResult]],
) -> LearnResult:
    """``run`` (e.g. :func:`babble`) on the bus of a Zenoh router embedded in this process
    (listening on ``listen``), the robot's nodes its local clients: how ``facesynth learn``
    babbles and ``facesynth plan`` rehearses."""
    async with embedded_bus(listen, zenoh, rig=rig) as (bus, _):
        freeze_startup_objects()
        return await run(bus)


async def babble(
    bus: Bus,
    rig: str,
    parts: dict[str, StageParts],
    shell: BabbleShell,
    session: SessionFile,
    *,
    frame_every: int = 30,
    record: list[str] | None = None,
    stats_interval: float = 1.0,
) -> LearnResult:
    """Run the robot's nodes (``parts``: sensor, points, features, control), the babbler and
    the recorder on ``bus`` until babbling ends; returns what was done."""
    started = time.monotonic()
    babbler = shell.babbler
    loop = asyncio.get_running_loop()
    nodes: dict[str, asyncio.Task[Any]] = {}
    interrupted = False

    def start(name: str) -> None:
        part = parts[name]
        ctx = node_context(bus, rig, part, stats_interval)
        nodes[name] = asyncio.create_task(run_service(ctx, part.body), name=name)

    chosen = list(record or RECORD_KEYS)
    recorder = Recorder(session.writer, RecordOptions(chosen, frame_every=frame_every))
    record_ctx = ServiceContext(bus, rig, "record", stats_interval=stats_interval)
    record_task = asyncio.create_task(run_service(record_ctx, recorder.serve), name="record")
    await asyncio.wait_for(recorder.listening.wait(), 10.0)
    for name in ("control", "points", "sensor"):
        start(name)
    shell.on_neutral = lambda: start("features")
    babble_ctx = ServiceContext(bus, rig, "learn", stats_interval=stats_interval)
    babble_task = asyncio.create_task(run_service(babble_ctx, shell.serve), name="learn")

    def stop() -> None:
        nonlocal interrupted
        if interrupted:  # a second Ctrl-C: stop at once
            babble_task.cancel()
            return
        interrupted = True
        log.info("stopping: back to neutral, keeping what was recorded")
        babbler.stop()

    for signum in (signal.SIGINT, signal.SIGTERM):
        with contextlib.suppress(NotImplementedError, RuntimeError):
            loop.add_signal_handler(signum, stop)
    failure: BaseException | None = None
    try:
        while not babble_task.done():
            ended = [t for t in nodes.values() if t.done()]
            for task in ended:
                if task.cancelled() or task.exception() is None:
                    if task.get_name() == "sensor" and not babbler.done:
                        log.warning("the camera's frames ended: babbling stops")
                        babbler.stop()
                    continue
                failure = task.exception()
                babble_task.cancel()
                break
            if failure is not None or record_task.done():
                babble_task.cancel()
                break
            await asyncio.wait([babble_task], timeout=0.1)
        try:
            await babble_task
        except asyncio.CancelledError:
            pass
        except Exception as exc:  # raised once the recording is complete
            failure = failure or exc
    finally:
        for signum in (signal.SIGINT, signal.SIGTERM):
            with contextlib.suppress(NotImplementedError, RuntimeError):
                loop.remove_signal_handler(signum)
        try:
            await cancel_and_wait(nodes.values())
            await asyncio.sleep(0.3)  # the last states and samples reach the recorder
        finally:  # the recording is completed even when this stop is cancelled
            await stop_tasks([record_task])
            shell.progress.close()
    session.close()
    if failure is not None:
        raise failure
    return LearnResult(
        taken=babbler.taken,
        skipped=babbler.skipped,
        next_pose=babbler.index,
        seconds=time.monotonic() - started,
        interrupted=interrupted,
        recorded=recorder.recorded[keys.stage_key(rig, "babble")],
        reached=dict(babbler.reached),
        streamed=babbler.streamed,
    )
