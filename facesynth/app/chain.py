"""Run services: one per process (``facesynth sensor`` …) or the whole chain in one process.

``facesynth run`` opens one Zenoh session in router mode (so other processes, ``facesynth
status`` or a remote control interface, can join) and runs the five stages on it; each stage
still publishes and subscribes on its own keys, exactly as when they run apart.
"""

from __future__ import annotations

import asyncio
import gc
import logging
import time
from collections.abc import Awaitable, Callable, Mapping
from dataclasses import dataclass
from typing import Any

from facesynth.runtime.bus.base import Bus
from facesynth.runtime.bus.zenoh_bus import (
    ZenohBus,
    ZenohConfigError,
    ZenohOptions,
    open_session,
    router_locators,
)
from facesynth.runtime.service import ServiceContext, run_service, until_signalled
from services.control.service import ControlService
from services.sensor.service import SensorService

log = logging.getLogger("facesynth")

ServiceBody = Callable[[ServiceContext], Awaitable[Any]]


async def run_single(
    options: ZenohOptions,
    rig: str,
    service: str,
    body: ServiceBody,
    *,
    instance: str | None = None,
    stats_interval: float = 1.0,
) -> Any:
    """Open a bus, run one service until it ends or a signal arrives, close the bus."""
    bus = await asyncio.to_thread(ZenohBus.open, options)
    freeze_startup_objects()
    try:
        ctx = ServiceContext(bus, rig, service, stats_interval=stats_interval)
        if instance:
            ctx.instance = instance
        return await until_signalled(run_service(ctx, body))
    finally:
        await bus.close()


def freeze_startup_objects() -> None:
    """Keep everything loaded so far (it lives for the whole run) out of the garbage
    collector's passes, which otherwise stall a stage for milliseconds now and then."""
    gc.collect()
    gc.freeze()


def open_embedded(listen: list[str], options: ZenohOptions) -> tuple[Any, list[str]]:
    """A router session for ``facesynth run``; falls back to a free port if ``listen`` is taken."""
    try:
        session = open_session(
            ZenohOptions(**{**options.__dict__, "mode": "router", "listen": listen})
        )
    except ZenohConfigError as exc:
        fallback = ["tcp/127.0.0.1:0"]
        if listen == fallback:
            raise
        log.warning("cannot listen on %s (%s); using a free port instead", ", ".join(listen), exc)
        session = open_session(
            ZenohOptions(**{**options.__dict__, "mode": "router", "listen": fallback})
        )
    return session, router_locators(session)


@dataclass
class ChainResult:
    """What a chain run did."""

    frames: int
    commands: int
    last_frame: int
    rejected: dict[str, int]
    dropped: dict[str, int]
    seconds: float
    interrupted: bool


async def run_chain(
    bus: Bus,
    rig: str,
    sensor: SensorService,
    bodies: Mapping[str, ServiceBody],
    control: ControlService,
    *,
    drain_timeout: float = 3.0,
    stats_interval: float = 1.0,
) -> ChainResult:
    """Run sensor, points, features, translator and control on one bus until the input ends.

    ``bodies`` holds the points, features and translator service bodies. After the sensor's
    last frame, waits until the control interface has executed it (or nothing has moved for
    ``drain_timeout`` seconds), then stops every stage.
    """
    contexts: dict[str, ServiceContext] = {}
    tasks: list[asyncio.Task[Any]] = []
    started = time.monotonic()

    def start(name: str, body: ServiceBody) -> ServiceContext:
        ctx = ServiceContext(bus, rig, name, stats_interval=stats_interval)
        contexts[name] = ctx
        tasks.append(asyncio.create_task(run_service(ctx, body), name=name))
        return ctx

    start("control", control.serve)
    for name, body in bodies.items():
        start(name, body)
    sensor.options.wait_for = ["control", *bodies]
    interrupted = False
    try:
        sensor_ctx = ServiceContext(bus, rig, "sensor", stats_interval=stats_interval)
        contexts["sensor"] = sensor_ctx
        sensor_task = asyncio.create_task(run_service(sensor_ctx, sensor.serve), name="sensor")
        for task in tasks:  # a stage that fails at start-up (driver, model) ends the run
            task.add_done_callback(
                lambda t: sensor_task.cancel() if not t.cancelled() and t.exception() else None
            )
        result = await until_signalled(sensor_task)
        if result is None:
            interrupted = True
        else:
            await _drain(control, sensor.last_seq, drain_timeout)
    except asyncio.CancelledError:
        interrupted = True
    finally:
        for task in tasks:
            task.cancel()
        outcomes = await asyncio.gather(*tasks, return_exceptions=True)
    for outcome in outcomes:
        if isinstance(outcome, BaseException) and not isinstance(outcome, asyncio.CancelledError):
            raise outcome
    return ChainResult(
        frames=sensor.last_seq + 1,
        commands=contexts["control"].stats.published,
        last_frame=control.last_frame,
        rejected={name: ctx.stats.rejected for name, ctx in contexts.items()},
        dropped={name: ctx.dropped() for name, ctx in contexts.items()},
        seconds=time.monotonic() - started,
        interrupted=interrupted,
    )


async def _drain(control: ControlService, last_seq: int, timeout: float) -> None:
    """Wait until ``control`` executed frame ``last_seq`` or made no progress for ``timeout``."""
    while control.last_frame < last_seq:
        control.progress.clear()
        try:
            await asyncio.wait_for(control.progress.wait(), timeout)
        except TimeoutError:
            log.warning(
                "the chain stopped before the last frame (%d; last executed %d)",
                last_seq,
                control.last_frame,
            )
            return
