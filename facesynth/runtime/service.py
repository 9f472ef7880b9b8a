"""What every facesynth service shares: its context on the bus, its main loop, its process.

A service is an ``async`` function taking a :class:`ServiceContext`. The runtime announces it
with a liveliness token, publishes its :class:`ServiceStats` every ``stats_interval`` seconds,
counts and logs rejected messages (never crashing on them), and stops it cleanly on SIGINT or
SIGTERM. The context carries the service's :class:`~facesynth.runtime.clock.Clock`: shells read
and wait on ``ctx.clock``, so a test can run them in virtual time (see
:mod:`facesynth.runtime.testing`).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import signal
import socket
import traceback
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any, TypeVar

import msgspec

from facesynth.runtime import codec, keys, limits
from facesynth.runtime.bus.base import Bus, Subscription, Token
from facesynth.runtime.capture_age import CaptureAge
from facesynth.runtime.clock import Clock, SystemClock
from facesynth.runtime.clock_host import clock_host
from facesynth.runtime.stats import StageStats

M = TypeVar("M")
Body = Callable[["ServiceContext"], Awaitable[Any]]

log = logging.getLogger("facesynth")


def host_id() -> str:
    """This host's name as it starts every instance id made here (see :func:`default_instance`)."""
    host = "".join(c if c.isalnum() or c in "-_." else "-" for c in socket.gethostname())[:40]
    return host or "host"


def default_instance() -> str:
    """An instance id unique on this network: host name and process id."""
    return f"{host_id()}-{os.getpid()}"


@dataclass
class ServiceContext:
    """One service instance's view of the bus, its clock and its running figures."""

    bus: Bus
    rig: str
    service: str
    instance: str = field(default_factory=default_instance)
    stats_interval: float = 1.0
    clock: Clock = field(default_factory=SystemClock)
    #: The robot this translator or control interface serves, when a rig drives several:
    #: its command and state keys are then ``…/servo_commands/<robot>``, ``…/servo_state/<robot>``.
    robot: str | None = None

    def __post_init__(self) -> None:
        keys.check_name(self.rig)
        keys.check_name(self.service, "service")
        keys.check_name(self.instance, "instance")
        if self.robot is not None:
            keys.check_name(self.robot, "robot")
        self.stats = StageStats(self.service, self.instance, self.rig)
        self.stats.started_ns = self.clock.time_ns()
        self.log = logging.getLogger(f"facesynth.{self.service}")
        self.subscriptions: list[Subscription] = []
        self._reject_logged = 0
        self._token: Token | None = None

    def ready(self) -> None:
        """Announce this service (liveliness token) once its subscriptions exist."""
        if self._token is None:
            self._token = self.bus.declare_token(
                keys.health_key(self.rig, self.service, self.instance)
            )

    def withdraw(self) -> None:
        """Withdraw the liveliness token."""
        if self._token is not None:
            self._token.close()
            self._token = None

    def key(self, stage: keys.Stage) -> str:
        """This rig's key for ``stage`` (this robot's, for the per-robot stages)."""
        robot = self.robot if stage in keys.ROBOT_STAGES else None
        return keys.stage_key(self.rig, stage, robot)

    def subscribe(
        self,
        stage: keys.Stage,
        maxsize: int,
        message: type[Any] | None = None,
        check: Callable[[Any], object] | None = None,
        *,
        every_robot: bool = False,
    ) -> Subscription:
        """Subscribe to a stage: latest-only when ``maxsize`` is 1, else queued. With
        ``every_robot``, to every robot's key of a per-robot stage too (:func:`keys.robots_pattern`:
        observers of a whole rig, such as the recorder).

        Payloads over the stage's size limit (:mod:`facesynth.runtime.limits`) are refused on
        arrival, undecoded; with ``message`` (the stage's message type) every payload is also
        decoded and checked on arrival (:func:`codec.decode`, on the transport's thread), so
        only valid messages enter the queue, as ``Sample.message``: a flood of bad messages
        never crowds the stream out. ``check`` (pure, thread-safe: it runs on the transport's
        thread) may refuse a decoded message too, by raising ``ValueError``. Refusals are
        counted as rejected and logged.

        A message published as an object in this process (:meth:`publish`) is taken as it is,
        with the same checks but no decoding (:func:`codec.check`, then ``check``); without
        ``message`` the mailbox gets its bytes.
        """
        key = keys.robots_pattern(self.rig, stage) if every_robot else self.key(stage)
        if maxsize <= 1:
            subscription = self.bus.subscribe_latest(key)
        else:
            subscription = self.bus.subscribe_queued(key, maxsize)
        limit = limits.stage_limit(stage)

        def refused(count: int, reason: str) -> None:
            self.stats.received += count  # received, and refused at once
            self.reject(f"{key}: {count} message(s) refused on arrival, the last: {reason}", count)

        screen = take = None
        if message is not None:

            def screen(payload: bytes) -> Any:
                decoded = codec.decode(payload, message)
                if check is not None:
                    check(decoded)
                return decoded

            def take(obj: Any) -> Any:
                checked = codec.check(obj, message)
                if check is not None:
                    check(checked)
                return checked

        subscription.guard(limit, screen, refused, take)
        self.subscriptions.append(subscription)
        return subscription

    def publish(
        self,
        stage: keys.Stage,
        message: msgspec.Struct,
        encode: Callable[[Any], bytes] = codec.encode,
    ) -> None:
        """Publish ``message`` on a stage key, and count it: as the object to this process's
        readers, encoded once for the others (:meth:`Bus.publish_message`; ``encode`` makes
        those bytes, msgpack by default). It is shared from here on and must not be changed
        (the message structs are frozen)."""
        self.bus.publish_message(self.key(stage), message, encode)
        self.stats.record_published(getattr(message, "t_capture_ns", 0), self.clock.time_ns())

    def reject(self, reason: str, count: int = 1) -> None:
        """Count ``count`` unusable inputs and log them: the first ten times, then each time
        the count passes a hundred more (a batch of refusals is one call)."""
        before = self.stats.rejected
        self.stats.rejected += count
        if self._reject_logged < 10 or before // 100 != self.stats.rejected // 100:
            self._reject_logged += 1
            self.log.warning("dropped a message (%d so far): %s", self.stats.rejected, reason)

    def dropped(self) -> int:
        """Samples the subscriptions overwrote because the service was busy."""
        return sum(sub.dropped for sub in self.subscriptions)

    def publish_stats(self, note: str = "") -> None:
        """Publish the current figures on this instance's stats key."""
        self.stats.dropped = self.dropped()
        snapshot = self.stats.snapshot(self.clock.time_ns(), note=note, link=self.bus.link())
        key = keys.stats_key(self.rig, self.service, self.instance)
        self.bus.publish_message(key, snapshot, codec.encode)


async def serve_transform(
    ctx: ServiceContext,
    in_stage: keys.Stage,
    in_type: type[M],
    out_stage: keys.Stage,
    transform: Callable[[M], msgspec.Struct | None],
    maxsize: int,
    listening: str = "",
    max_age_s: float | None = None,
) -> None:
    """Decode each input, transform it, publish the result; reject what cannot be used.
    ``listening`` is logged once the service listens (operators and tests wait for it).

    With ``max_age_s``, an input whose frame was captured longer ago than that when it leaves
    the input queue is dropped untransformed and counted in ``stats.stale``
    (:class:`~facesynth.runtime.capture_age.CaptureAge`, logged once per run of them): after a
    stall upstream the stage goes on with fresh frames, never with the backlog."""
    subscription = ctx.subscribe(in_stage, maxsize, in_type)
    ages = None if max_age_s is None else CaptureAge(max_age_s, clock_host())
    ctx.ready()
    if listening:
        ctx.log.info("%s", listening)
    async for sample in subscription:
        ctx.stats.received += 1
        try:
            message = sample.message  # decoded and checked on arrival
            if message is None:
                message = codec.decode(sample.payload, in_type)  # type: ignore[type-var]
            if ages is not None and _captured_too_long_ago(ctx, ages, message):
                continue
            result = transform(message)
        except ValueError as exc:
            ctx.reject(f"{sample.key}: {exc}")
            continue
        except Exception:  # a bug must not stop the robot's face: count it, log it, go on
            ctx.reject(f"{sample.key}: internal error\n{traceback.format_exc()}")
            continue
        if result is not None:
            ctx.publish(out_stage, result)


def _captured_too_long_ago(ctx: ServiceContext, ages: CaptureAge, message: object) -> bool:
    """Whether ``message`` is too old since capture (counted, and said once per run)."""
    verdict = ages.check(
        getattr(message, "t_capture_ns", 0),
        getattr(message, "capture_host", ""),
        ctx.clock.time_ns(),
        ctx.clock.monotonic_ns(),
    )
    if verdict.note:
        ctx.log.warning("%s", verdict.note)
    if verdict.old:
        ctx.stats.stale += 1
    return verdict.old


async def _stats_loop(ctx: ServiceContext) -> None:
    while True:
        await ctx.clock.sleep(ctx.stats_interval)
        ctx.publish_stats()


async def run_service(ctx: ServiceContext, body: Body) -> Any:
    """Run ``body`` with periodic stats; withdraw its liveliness token when it ends.

    ``body`` calls :meth:`ServiceContext.ready` once it listens (``serve_transform`` does).
    """
    stats_task = asyncio.create_task(_stats_loop(ctx), name=f"{ctx.service}-stats")
    try:
        return await body(ctx)
    finally:
        stats_task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await stats_task
        with contextlib.suppress(Exception):
            ctx.publish_stats(note="stopped")
        ctx.withdraw()
        ctx.log.info(
            "stopped: received %d, published %d, dropped %d (input queue full), rejected %d",
            ctx.stats.received,
            ctx.stats.published,
            ctx.dropped(),
            ctx.stats.rejected,
        )


def run_async(main: Awaitable[M]) -> M:
    """Run a coroutine to completion on uvloop when installed, else the default loop."""
    try:
        import uvloop
    except ImportError:
        factory = None
    else:
        factory = uvloop.new_event_loop
    with asyncio.Runner(loop_factory=factory) as runner:
        return runner.run(main)  # type: ignore[arg-type]


async def until_signalled(main: Awaitable[M]) -> M | None:
    """Await ``main``; on SIGINT or SIGTERM cancel it and return ``None``."""
    loop = asyncio.get_running_loop()
    task = asyncio.ensure_future(main)
    stopping = False

    def stop() -> None:
        nonlocal stopping
        stopping = True
        task.cancel()

    for signum in (signal.SIGINT, signal.SIGTERM):
        with contextlib.suppress(NotImplementedError, RuntimeError):
            loop.add_signal_handler(signum, stop)
    try:
        return await task
    except asyncio.CancelledError:
        if stopping:
            return None
        raise
    finally:
        for signum in (signal.SIGINT, signal.SIGTERM):
            with contextlib.suppress(NotImplementedError, RuntimeError):
                loop.remove_signal_handler(signum)
