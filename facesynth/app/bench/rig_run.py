"""Run a graph as separate processes on a loopback router and measure it: the chain and fan-out
benchmarks' common runner.

Each process runs one node (``facesynth STAGE --graph G --node N``) or, for a group of nodes,
several of them in one process (``facesynth run SUBGRAPH``, a graph without a sensor). Every
process but the sensor's starts first; once all their nodes are alive on the bus, the sensor
plays a video in real time. While it plays, a :class:`~.observe.RigObserver` follows the rig; the
CPU window opens when the chain has applied frame ``steady_from`` and closes at ``steady_to``,
and every process's CPU time (the router's included) is divided by the frames in between. The
commands each control node applied come from its record file.
"""

from __future__ import annotations

import asyncio
import os
import subprocess
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from facesynth.app.bench.observe import RigObserver, Trigger, loadavg, machine_busy
from facesynth.app.bench.processes import CpuWindow, ProcessGroup
from facesynth.app.graph import Graph, graph_to_toml
from facesynth.app.nodes import ControlNode, stage_of
from facesynth.app.stages.registry import STAGES
from facesynth.runtime import keys
from facesynth.runtime.bus.zenoh_bus import ZenohBus, ZenohOptions
from facesynth.runtime.gc_watch import parse_summary
from facesynth.runtime.stats import memory_mb
from facesynth.schemas.messages import ServiceStats
from facesynth.services.control.drivers.record import RecordLine, read_record

#: The benchmark's own process in the CPU window (left out of the rig's figures).
OBSERVER = "(observer)"


class BenchRunError(RuntimeError):
    """A benchmark run that could not complete (a process failed; its log is in the message)."""


@dataclass
class RigRun:
    """What one run of a graph measured."""

    #: Commands applied by each control node (from its record file), by node name.
    records: dict[str, list[RecordLine]] = field(default_factory=dict)
    #: CPU milliseconds per frame of each process over the steady window (``router`` included).
    cpu_ms: dict[str, float] = field(default_factory=dict)
    #: Latest stats of each service instance (its own latency window), by service/instance.
    stats: dict[str, ServiceStats] = field(default_factory=dict)
    #: Peak resident memory of each process still running at the end (MB).
    peak_rss_mb: dict[str, float] = field(default_factory=dict)
    #: The whole machine's busy share of its cores during the window (0..1), and the share of
    #: the same that was not this benchmark's processes (other users of the machine).
    machine_busy: float = float("nan")
    others_busy: float = float("nan")
    load_before: float = float("nan")
    load_after: float = float("nan")
    #: Per-hop arrival times when the run watched hops (see RigObserver).
    observer: RigObserver | None = None
    steady_from: int = 0
    #: Garbage-collector passes of each process after its start-up, from its log: passes,
    #: generation-2 passes, longest pause (ms).
    gc: dict[str, tuple[int, int, float]] = field(default_factory=dict)

    def latencies_ms(self, node: str, *, steady: bool = True) -> list[float]:
        """Capture-to-command latencies (ms) of a control node's commands: of the frames from
        ``steady_from`` on, or (``steady=False``) of every frame."""
        since = self.steady_from if steady else 0
        return [
            (line.t_sent_ns - line.t_capture_ns) / 1e6  # type: ignore[operator]
            for line in self.records.get(node, [])
            if line.frame is not None and line.frame >= since
        ]


def process_layout(
    graph: Graph, groups: Mapping[str, Sequence[str]] | None
) -> dict[str, list[str]]:
    """Process name → the nodes it runs: one node per process unless ``groups`` says otherwise."""
    layout: dict[str, list[str]] = {name: list(nodes) for name, nodes in (groups or {}).items()}
    grouped = {node for nodes in layout.values() for node in nodes}
    for name in graph.nodes:
        if name not in grouped:
            layout[name] = [name]
    return layout


@dataclass
class RunOptions:
    """How a graph is run and watched."""

    frames: int
    fps: float
    mode: str = "client"
    steady_after_s: float = 2.0
    hops: bool = False
    #: Groups of nodes run together in one process, by process name.
    groups: Mapping[str, Sequence[str]] | None = None
    startup_timeout: float = 180.0
    #: Extra options of ``facesynth router`` (its scheduling).
    router_args: Sequence[str] = ()
    #: The robot whose applied commands time the CPU window (default: every robot's).
    progress_robot: str | None = None
    #: Another facesynth source tree the processes run instead of this one (see ProcessGroup).
    source: str | None = None


def run_graph(graph: Graph, options: RunOptions) -> RigRun:
    """Run ``graph`` (its sensor plays ``options.frames`` frames) and measure it."""
    layout = process_layout(graph, options.groups)
    sources = STAGES.sources()
    sensors = [p for p, nodes in layout.items() if stage_of(graph.nodes[nodes[0]]) in sources]
    if len(sensors) != 1 or len(layout[sensors[0]]) != 1:
        raise BenchRunError("the benchmark graph needs one sensor node, in a process of its own")
    sensor = sensors[0]
    with tempfile.TemporaryDirectory(prefix="facesynth-bench-") as tmp:
        group = ProcessGroup(Path(tmp), options.source)
        try:
            locator = group.start_router(*options.router_args)
            starts = _commands(graph, layout, Path(tmp), locator, options.mode)
            for process in reversed(list(layout)):  # downstream first
                if process != sensor:
                    group.start(process, *starts[process])
            run = asyncio.run(
                _watch(
                    group,
                    graph,
                    locator,
                    lambda: group.start(sensor, *starts[sensor]),
                    options,
                )
            )
            if failed := group.failed([sensor]):
                raise BenchRunError(f"the sensor failed:\n{failed[sensor]}")
            run.peak_rss_mb = {
                name: memory_mb(proc.pid)[1]
                for name, proc in group.procs.items()
                if proc.poll() is None
            }
            others = [name for name in group.procs if name not in ("router", sensor)]
            group.stop(others)
            if failed := group.failed(others):
                name, log = next(iter(failed.items()))
                raise BenchRunError(f"{name} failed:\n{log}")
            for name in group.procs:
                summary = parse_summary(group.log(name).read_text(errors="replace"))
                if summary is not None:
                    run.gc[name] = summary
            run.records = {
                name: [
                    line
                    for line in read_record(node.driver["out"])
                    if line.frame is not None and line.t_capture_ns
                ]
                for name, node in graph.nodes.items()
                if isinstance(node, ControlNode) and node.driver.get("driver") == "record"
            }
        finally:
            group.close()
    return run


def _commands(
    graph: Graph, layout: dict[str, list[str]], folder: Path, locator: str, mode: str
) -> dict[str, list[str]]:
    """The ``facesynth`` arguments of each process."""
    common = ["--connect", locator, "--rig", graph.rig, "--stats-interval", "0.5", "--mode", mode]
    graph_file = folder / "bench.toml"
    graph_file.write_text(graph_to_toml(graph))
    starts = {}
    for process, nodes in layout.items():
        if len(nodes) == 1:
            stage = stage_of(graph.nodes[nodes[0]])
            starts[process] = [stage, "--graph", str(graph_file), "--node", nodes[0], *common]
        else:
            sub = Graph(
                rig=graph.rig,
                description=process,
                nodes={name: graph.nodes[name] for name in nodes},
            )
            sub_file = folder / f"{process}.toml"
            sub_file.write_text(graph_to_toml(sub))
            starts[process] = ["run", str(sub_file), *common]
    return starts


async def _wait_alive(
    bus: ZenohBus, group: ProcessGroup, rig: str, count: int, timeout: float
) -> None:
    """Until ``count`` services of the rig are alive (or a process fails, or time is up)."""
    deadline = time.monotonic() + timeout
    while True:
        alive = await bus.alive(keys.health_pattern(rig), timeout=1.0)
        if len(alive) >= count:
            return
        if failed := group.failed():
            name, log = next(iter(failed.items()))
            raise BenchRunError(f"{name} failed:\n{log}")
        if time.monotonic() > deadline:
            raise BenchRunError(
                f"only {len(alive)} of {count} services were alive after {timeout:.0f} s"
            )
        await asyncio.sleep(0.2)


async def _watch(
    group: ProcessGroup,
    graph: Graph,
    locator: str,
    start_sensor: Callable[[], subprocess.Popen[bytes]],
    options: RunOptions,
) -> RigRun:
    steady_from = min(options.frames - 1, int(options.steady_after_s * options.fps))
    steady_to = max(steady_from + 1, options.frames - 1 - int(0.5 * options.fps))
    bus = ZenohBus.open(ZenohOptions(mode="client", connect=[locator]))
    marks: dict[str, tuple[int, tuple[float, float] | None]] = {}
    cpu = CpuWindow({})

    def mark(name: str) -> Callable[[int], None]:
        def action(seq: int) -> None:
            (cpu.start if name == "start" else cpu.stop)()
            marks[name] = (seq, machine_busy())

        return action

    observer = RigObserver(
        bus,
        graph.rig,
        hops=options.hops,
        triggers=[Trigger(steady_from, mark("start")), Trigger(steady_to, mark("stop"))],
        progress_robot=options.progress_robot,
    )
    try:
        await _wait_alive(bus, group, graph.rig, len(graph.nodes) - 1, options.startup_timeout)
        observer.start()
        load_before = loadavg()
        sensor = start_sensor()
        # The observer (this process) is measured too: it is the machine's load, not the rig's.
        cpu.pids = {**group.pids(), OBSERVER: os.getpid()}
        started = time.monotonic()
        while sensor.poll() is None:
            if failed := group.failed():
                name, log = next(iter(failed.items()))
                raise BenchRunError(f"{name} failed:\n{log}")
            if observer.last_seq < 0 and time.monotonic() - started > options.startup_timeout:
                raise BenchRunError(f"no command applied within {options.startup_timeout:.0f} s")
            await asyncio.sleep(0.1)
        await asyncio.sleep(1.5)  # the last commands and stats
    finally:
        await observer.close()
        await bus.close()
    if "start" not in marks:
        raise BenchRunError("the chain never reached its steady state (no commands applied)")
    if "stop" not in marks:  # the chain stopped early: close the window at the end
        mark("stop")(observer.last_seq)
    (seq0, busy0), (seq1, busy1) = marks["start"], marks["stop"]
    run = RigRun(
        cpu_ms={k: v for k, v in cpu.per_frame_ms(seq1 - seq0).items() if k != OBSERVER},
        stats=observer.stats,
        load_before=load_before,
        load_after=loadavg(),
        observer=observer,
        steady_from=steady_from,
    )
    if busy0 and busy1:
        busy, total = busy1[0] - busy0[0], busy1[1] - busy0[1]
        ours = sum(cpu.used.values())
        if total > 0:  # /proc/stat counts every core: ``total`` is cores x seconds
            # busy <= total in ticks; the float differences can round past 1 on a full machine
            run.machine_busy = min(1.0, busy / total)
            run.others_busy = min(run.machine_busy, max(0.0, busy - ours) / total)
    return run
