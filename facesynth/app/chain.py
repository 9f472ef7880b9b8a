"""Run services: one per process (``facesynth sensor`` …) or the whole chain in one process.

``facesynth run`` opens one Zenoh session in router mode (so other processes, ``facesynth
status`` or a remote control interface, can join) and runs the five stages on it; each stage
still publishes and subscribes on its own keys, exactly as when they run apart.
"""

from __future__ import annotations

import asyncio
import gc
import logging
import sys
import threading
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Any

import msgspec

from facesynth.app.graph import Graph
from facesynth.app.profile_choice import settle
from facesynth.app.stages.registry import STAGES
from facesynth.app.stages.setup import Setup
from facesynth.app.wiring import OptionError, StageParts, build_node, check_blendshapes
from facesynth.runtime import codec, keys, limits
from facesynth.runtime.bus.base import Bus
from facesynth.runtime.bus.zenoh_bus import ZenohBus, ZenohOptions
from facesynth.runtime.gc_watch import GcWatch
from facesynth.runtime.heap_trim import HeapTrimmer
from facesynth.runtime.memory import return_big_allocations
from facesynth.runtime.service import (
    ServiceContext,
    default_instance,
    run_service,
    until_signalled,
)
from facesynth.runtime.tasks import cancel_and_wait
from facesynth.schemas.messages import ServoCommands
from facesynth.services.points.backends.base import PointsBackend
from facesynth.services.sensor.service import SensorService

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
    robot: str | None = None,
) -> Any:
    """Open a bus (waiting for the router if the options say so: see :func:`open_waiting`),
    run one service until it ends or a signal arrives, close the bus."""
    sys.setswitchinterval(SWITCH_INTERVAL_S)
    return_big_allocations()
    bus = await open_waiting(
        options.with_message_limit(limits.session_limit(keys.CONSUMES.get(service)))
    )
    freeze_startup_objects()
    watch = GcWatch()
    watch.start()
    trimmer = HeapTrimmer()
    trimmer.start()
    try:
        ctx = ServiceContext(
            bus,
            rig,
            service,
            instance=instance or default_instance(),
            stats_interval=stats_interval,
            robot=robot,
        )
        return await until_signalled(run_service(ctx, body))
    finally:
        trimmer.stop()
        watch.stop()
        log.info("%s after start-up", watch.summary())
        await bus.close()


#: How long a thread holding the interpreter may keep it while another waits (seconds; Python's
#: default is 5 ms). Zenoh hands each message to Python on its own thread: under a flood of
#: messages that thread would otherwise make the service's event loop wait 5 ms for every turn.
SWITCH_INTERVAL_S = 0.0005
#: After this long without a router, a service says once that it is waiting for it.
WAIT_NOTICE_S = 1.0


async def open_waiting(options: ZenohOptions) -> ZenohBus:
    """Open a bus on a thread of its own (a daemon: Ctrl-C is not held up by a session still
    waiting for its router); after ``WAIT_NOTICE_S`` without it, say once that it waits."""
    loop = asyncio.get_running_loop()
    opened: asyncio.Future[ZenohBus] = loop.create_future()

    def open_bus() -> None:
        try:
            bus = ZenohBus.open(options)
        except BaseException as exc:  # handed to the loop, raised there
            loop.call_soon_threadsafe(_settle, opened, None, exc)
        else:
            loop.call_soon_threadsafe(_settle, opened, bus, None)

    started = time.monotonic()
    threading.Thread(target=open_bus, name="zenoh-open", daemon=True).start()
    done, _ = await asyncio.wait({opened}, timeout=WAIT_NOTICE_S)
    if done:
        return opened.result()
    where = ", ".join(options.connect) or "the configured endpoints"
    log.info(
        "waiting for the Zenoh router at %s (retrying with backoff; start one with: "
        "facesynth router)",
        where,
    )
    bus = await opened
    log.info("connected to the router after %.1f s", time.monotonic() - started)
    return bus


def _settle(
    future: asyncio.Future[ZenohBus], bus: ZenohBus | None, exc: BaseException | None
) -> None:
    if future.done():  # nobody waits any more (cancelled): close what was opened
        if bus is not None:
            threading.Thread(target=bus.session.close, daemon=True).start()
        return
    if exc is not None:
        future.set_exception(exc)
    else:
        future.set_result(bus)  # type: ignore[arg-type]


def freeze_startup_objects() -> None:
    """Keep everything loaded so far (it lives for the whole run) out of the garbage
    collector's passes, which otherwise stall a stage for milliseconds now and then."""
    gc.collect()
    gc.freeze()


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


def build_chain(
    graph: Graph, configs: dict[str, msgspec.Struct | None], setup: Setup | None = None
) -> list[StageParts]:
    """Every node of ``graph``, built, for one process: exactly one sensor, the rest any number.

    ``configs`` holds each node's validated plugin config; ``setup`` the chain's settled setup
    (:func:`facesynth.app.profile_choice.settle`; else settled here without filling in
    profiles), shared by every node, so each profile file is read once. A replayed point
    stream sets the number of frames when the sensor names no video; the tracker needs frames
    with pixels.
    """
    sensors = graph.sources()
    if len(sensors) != 1:
        raise OptionError(
            f"a graph run in one process needs one sensor node (found {len(sensors) or 'none'})"
        )
    setup = setup or _unsettled(graph, configs)
    parts = [
        build_node(name, node, graph, configs.get(name), setup=setup)
        for name, node in graph.nodes.items()
        if name not in sensors
    ]
    backends = [p.service for p in parts if isinstance(p.service, PointsBackend)]
    replay_frames = next((b.frame_count() for b in backends if b.frame_count() is not None), None)
    name, node = next(iter(sensors.items()))
    sensor = build_node(
        name, node, graph, configs.get(name), replay_frames=replay_frames, setup=setup
    )
    if any(b.needs_pixels() for b in backends) and sensor.service.source.info.name == "ticks":
        raise OptionError("the tracker needs images: give --video, --camera or --images")
    check_blendshapes(parts)
    return [sensor, *parts]


def _appliers() -> tuple[str, ...]:
    """The stages whose nodes apply commands (they write ``…/servo_state``): a chain has
    drained when they report its last frame, and what they publish are its commands."""
    return STAGES.producing("servo_state")


def _unsettled(graph: Graph, configs: dict[str, msgspec.Struct | None]) -> Setup:
    """The setup of a graph whose caller settled none: its profiles as its nodes name them."""
    given = {name: config for name, config in configs.items() if config is not None}
    return settle(graph, given, check=False, fill=False, plugins=False)


async def run_chain(
    bus: Bus,
    rig: str,
    parts: list[StageParts],
    *,
    drain_timeout: float = 3.0,
    stats_interval: float = 1.0,
) -> ChainResult:
    """Run every stage of ``parts`` on one bus until the sensor's input ends.

    The sensor (the first part) waits for the other stages' liveliness, then plays its source.
    After its last frame, the chain has drained when ``…/servo_state`` reports that frame, as
    any observer on the bus would see it (or when nothing has moved for ``drain_timeout``
    seconds); then every stage stops.
    """
    sensor_part, others = parts[0], parts[1:]
    sensor: SensorService = sensor_part.service
    contexts: dict[str, ServiceContext] = {}
    tasks: list[asyncio.Task[Any]] = []
    started = time.monotonic()
    progress = AppliedFrameWatch(bus, keys.robots_pattern(rig, "servo_state"))

    def context(part: StageParts) -> ServiceContext:
        contexts[part.name] = node_context(bus, rig, part, stats_interval)
        return contexts[part.name]

    for part in others:
        tasks.append(asyncio.create_task(run_service(context(part), part.body), name=part.name))
    sensor.options.wait_for = sorted({part.stage for part in others})
    interrupted = False
    try:
        sensor_task = asyncio.create_task(
            run_service(context(sensor_part), sensor.serve), name=sensor_part.name
        )
        for task in tasks:  # a stage that fails at start-up (driver, model) ends the run
            task.add_done_callback(
                lambda t: sensor_task.cancel() if not t.cancelled() and t.exception() else None
            )
        result = await until_signalled(sensor_task)
        if result is None:
            interrupted = True
        elif any(part.stage in _appliers() for part in others):
            await progress.wait_for(sensor.last_seq, drain_timeout)
    except asyncio.CancelledError:
        interrupted = True
    finally:
        progress.close()
        errors = await cancel_and_wait(tasks)
    if errors:
        raise errors[0]
    controls = [contexts[p.name] for p in others if p.stage in _appliers()]
    return ChainResult(
        frames=sensor.last_seq + 1,
        commands=sum(ctx.stats.published for ctx in controls),
        last_frame=progress.last_seq,
        rejected={name: ctx.stats.rejected for name, ctx in contexts.items()},
        dropped={name: ctx.dropped() for name, ctx in contexts.items()},
        seconds=time.monotonic() - started,
        interrupted=interrupted,
    )


def node_context(bus: Bus, rig: str, part: StageParts, stats_interval: float) -> ServiceContext:
    """The service context of one node of a graph run in one process."""
    instance = default_instance()
    if part.name != part.stage:
        instance = f"{instance}-{part.name}"
    # The instance is given at construction: the stats messages carry it too.
    return ServiceContext(
        bus, rig, part.stage, instance=instance, stats_interval=stats_interval, robot=part.robot
    )


def build_nodes(
    graph: Graph, configs: dict[str, msgspec.Struct | None], setup: Setup | None = None
) -> list[StageParts]:
    """Every node of a graph without a sensor, built, for one process (for instance a robot
    host's translators and control interfaces, fed by a performer's chain elsewhere)."""
    if graph.sources():
        raise OptionError("build_nodes is for graphs without a sensor (see build_chain)")
    setup = setup or _unsettled(graph, configs)
    parts = [
        build_node(name, node, graph, configs.get(name), setup=setup)
        for name, node in graph.nodes.items()
    ]
    check_blendshapes(parts)
    return parts


async def serve_nodes(
    bus: Bus, rig: str, parts: list[StageParts], *, stats_interval: float = 1.0
) -> ChainResult:
    """Run nodes that need no sensor of their own until a signal arrives or one of them fails."""
    started = time.monotonic()
    watch = GcWatch()
    watch.start()
    contexts = {part.name: node_context(bus, rig, part, stats_interval) for part in parts}
    tasks = [
        asyncio.create_task(run_service(contexts[part.name], part.body), name=part.name)
        for part in parts
    ]
    outcome = await until_signalled(asyncio.wait(tasks, return_when=asyncio.FIRST_EXCEPTION))
    try:
        errors = await cancel_and_wait(tasks)
    finally:
        watch.stop()
    log.info("%s after start-up", watch.summary())
    if errors:
        raise errors[0]
    controls = [contexts[p.name] for p in parts if p.stage in _appliers()]
    return ChainResult(
        frames=0,
        commands=sum(ctx.stats.published for ctx in controls),
        last_frame=-1,
        rejected={name: ctx.stats.rejected for name, ctx in contexts.items()},
        dropped={name: ctx.dropped() for name, ctx in contexts.items()},
        seconds=time.monotonic() - started,
        interrupted=outcome is None,
    )


class AppliedFrameWatch:
    """Follows ``…/servo_state`` (``key`` may match every robot's) on the bus: the last frame
    a control interface applied."""

    def __init__(self, bus: Bus, key: str) -> None:
        self.last_seq = -1
        self._subscription = bus.subscribe_latest(key)
        # Checked on arrival; a controller of this process hands its reports over undecoded.
        self._subscription.guard(
            limits.stage_limit("servo_state"),
            lambda payload: codec.decode(payload, ServoCommands),
            take=lambda message: codec.check(message, ServoCommands),
        )
        self._task = asyncio.create_task(self._follow(), name="servo-state-watch")
        self._progress = asyncio.Event()

    async def _follow(self) -> None:
        async for sample in self._subscription:
            state: ServoCommands = sample.message
            if state.move != "command":  # the controller's own move: no frame applied
                continue
            seq = state.seq
            self.last_seq = max(self.last_seq, seq)
            self._progress.set()

    async def wait_for(self, seq: int, timeout: float) -> None:
        """Until frame ``seq`` was applied, or nothing was applied for ``timeout`` seconds."""
        while self.last_seq < seq:
            self._progress.clear()
            try:
                async with asyncio.timeout(timeout):
                    await self._progress.wait()
            except TimeoutError:
                log.warning(
                    "the chain stopped before the last frame (%d; last applied %d)",
                    seq,
                    self.last_seq,
                )
                return

    def close(self) -> None:
        """Stop following."""
        self._subscription.close()
        self._task.cancel()
