"""``facesynth bench chain``: the five services as separate processes on a loopback router.

Plays a video in real time through S → P → F → T → C (record driver) and measures, for each
variant asked for (frame encoding, tracker model, tracker threads, Zenoh mode: their cross
product, compared side by side in one run, the runs interleaved), capture → command latency at
C (the whole run, and the steady state after the first seconds), each stage's own
capture → publish latency, the CPU time each process (the router's included) spends per frame,
and peak memory; with ``hops``, where each frame's time goes hop by hop and which hops grow in
the slowest frames. A variant's ``layout`` runs every service in a process of its own
(``processes``) or the board side, F + T + C, in one process (``board``, a ``facesynth run`` of
those three nodes, as on the board near the robot). The report prints the goals and the CPU
budget of each stage (:mod:`.budget`) against the figures.
"""

from __future__ import annotations

import itertools
import os
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from facesynth.app.bench.rig_run import RigRun, RunOptions, run_graph
from facesynth.app.compose import TRACKER_STAGES
from facesynth.app.data import sample_video
from facesynth.app.graph import Graph
from facesynth.app.nodes import (
    ControlNode,
    FeaturesNode,
    PointsNode,
    SensorNode,
    TranslatorNode,
)
from facesynth.app.stages.registry import STAGES as REGISTRY
from facesynth.runtime import keys

STAGES = keys.SERVICES
#: Frames of the first seconds (start-up and F's neutral window) left out of "steady state".
STEADY_AFTER_S = 2.0
#: The goals of issue 19 for the chain with the ``full`` model at 30 fps on 2 cores: capture →
#: command latency (five processes, and the board side as one process) and CPU per frame of the
#: five-process chain, the router included (each stage's own budget is in :mod:`.budget`).
GOAL_P50_MS = 10.0
GOAL_P99_MS = 20.0
GOAL_CPU_MS = 10.0
#: Process layouts of the chain: one process per service, or F + T + C in one ``board`` process.
LAYOUTS = ("processes", "board")
BOARD = "board"
#: The board process's nodes: the stages that neither make nor read frames (named as their stage).
BOARD_NODES = tuple(name for name in REGISTRY.names() if name not in TRACKER_STAGES)
#: What a chain's sensor waits for: every stage that reads something.
READERS = [stage.name for stage in REGISTRY if stage.consumes is not None]
#: ``--sched realtime``: every process of the chain (the router included) at this SCHED_FIFO
#: priority.
REALTIME_PRIORITY = 10
SCHEDULES = ("normal", "realtime")


@dataclass(frozen=True)
class ChainVariant:
    """One configuration of the chain: what a user picks."""

    encoding: str = "jpeg"
    model: str = "full"
    threads: int = 1
    mode: str = "client"
    sched: str = "normal"
    #: ``processes`` (one per service) or ``board`` (F + T + C in one process).
    layout: str = "processes"
    #: Another facesynth source tree to run the processes from (a baseline), if any.
    source: str = ""

    def label(self) -> str:
        """A short name, e.g. ``raw fast client``, ``jpeg full peer realtime``, ``jpeg full
        client board`` or ``jpeg full client [/src/old]``."""
        threads = f" {self.threads} threads" if self.threads != 1 else ""
        sched = f" {self.sched}" if self.sched != "normal" else ""
        layout = f" {self.layout}" if self.layout != "processes" else ""
        source = f" [{Path(self.source).name or self.source}]" if self.source else ""
        return f"{self.encoding} {self.model}{threads} {self.mode}{sched}{layout}{source}"

    def groups(self) -> dict[str, list[str]] | None:
        """The nodes run together in one process, by process name (``None``: none)."""
        return {BOARD: list(BOARD_NODES)} if self.layout == BOARD else None

    @property
    def realtime(self) -> int | None:
        """The real-time priority of every process, if any."""
        return REALTIME_PRIORITY if self.sched == "realtime" else None

    def router_args(self) -> list[str]:
        """``facesynth router`` options for this variant."""
        return ["--realtime", str(self.realtime)] if self.realtime else []


def variants(
    encodings: Sequence[str] = ("jpeg",),
    models: Sequence[str] = ("full",),
    threads: Sequence[int] = (1,),
    modes: Sequence[str] = ("client",),
    scheds: Sequence[str] = ("normal",),
    baseline: str = "",
    layouts: Sequence[str] = ("processes",),
) -> list[ChainVariant]:
    """Every combination of the options, in the order given; with ``baseline`` (another
    facesynth source tree), each combination without real-time scheduling also runs from it,
    right after the same combination from this one."""
    out = []
    for combination in itertools.product(encodings, models, threads, modes, scheds, layouts):
        out.append(ChainVariant(*combination))
        if baseline and out[-1].sched == "normal":
            out.append(ChainVariant(*combination, source=baseline))
    return out


@dataclass
class ChainFigures:
    """Figures of one run of one variant."""

    variant: ChainVariant
    run: int
    frames_sent: int
    commands: int
    fps: float
    backend: str
    #: capture → command at C (ms): p50, p99, max; for the whole run and for the steady state.
    whole_ms: tuple[float, float, float]
    steady_ms: tuple[float, float, float]
    commands_per_s: float
    #: Each stage's capture → publish p50/p99 (its own stats window), dropped inputs.
    stage_ms: dict[str, tuple[float, float]] = field(default_factory=dict)
    dropped: dict[str, int] = field(default_factory=dict)
    cpu_ms: dict[str, float] = field(default_factory=dict)
    peak_rss_mb: dict[str, float] = field(default_factory=dict)
    machine_busy: float = float("nan")
    others_busy: float = float("nan")
    load: tuple[float, float] = (float("nan"), float("nan"))
    #: With hops: per hop p50/p99 (ms), and per hop median over all vs the slowest 1 %.
    hops: dict[str, tuple[float, float]] = field(default_factory=dict)
    tail: dict[str, tuple[float, float]] = field(default_factory=dict)
    #: Garbage-collector passes after start-up per process: passes, generation 2, longest ms.
    gc: dict[str, tuple[int, int, float]] = field(default_factory=dict)

    @property
    def cpu_total_ms(self) -> float:
        """CPU per frame of the whole chain, the router included."""
        return float(sum(self.cpu_ms.values())) if self.cpu_ms else float("nan")


def bench_graph(
    variant: ChainVariant,
    *,
    video: str,
    fps: float,
    frames: int,
    openface_csv: str | None,
    record: Path,
    rig: str,
) -> Graph:
    """The benchmark's chain: the video looped in real time, tracker (or a replay), record."""
    realtime = variant.realtime
    backend: dict[str, Any] = (
        {"backend": "openface", "csv": openface_csv, "loop": True}
        if openface_csv
        else {"backend": "tracker", "threads": variant.threads, "model": variant.model}
    )
    return Graph(
        rig=rig,
        description="facesynth bench chain",
        nodes={
            "sensor": SensorNode(
                source={"source": "video", "path": video, "loop": True, "fps": fps},
                max_frames=frames,
                encoding=variant.encoding,  # type: ignore[arg-type]
                wait_for=list(READERS),
                wait_timeout=60.0,
                realtime=realtime,
            ),
            "points": PointsNode(backend=backend, realtime=realtime),
            "features": FeaturesNode(realtime=realtime),
            "translator": TranslatorNode(realtime=realtime),
            "control": ControlNode(
                driver={"driver": "record", "out": str(record)}, realtime=realtime
            ),
        },
    )


def latency_figures(values: np.ndarray) -> tuple[float, float, float]:
    """p50, p99 and max of some milliseconds (NaN when there are none)."""
    if not values.size:
        return float("nan"), float("nan"), float("nan")
    p50, p99, worst = np.percentile(values, [50, 99, 100])
    return float(p50), float(p99), float(worst)


def bench_chain_once(
    variant: ChainVariant,
    *,
    video: str | None = None,
    seconds: float = 15.0,
    fps: float = 30.0,
    openface_csv: str | None = None,
    hops: bool = False,
    run: int = 1,
) -> ChainFigures:
    """Run the chain once with ``variant`` and return its figures."""
    frames = max(1, int(seconds * fps))
    with tempfile.TemporaryDirectory(prefix="facesynth-bench-records-") as tmp:
        graph = bench_graph(
            variant,
            video=video or str(sample_video()),
            fps=fps,
            frames=frames,
            openface_csv=openface_csv,
            record=Path(tmp) / "commands.jsonl",
            rig=f"bench{os.getpid()}",
        )
        result = run_graph(
            graph,
            RunOptions(
                frames=frames,
                fps=fps,
                mode=variant.mode,
                steady_after_s=STEADY_AFTER_S,
                hops=hops,
                router_args=variant.router_args(),
                source=variant.source or None,
                groups=variant.groups(),
            ),
        )
    return chain_figures(
        variant,
        result,
        frames=frames,
        fps=fps,
        run=run,
        backend="openface replay" if openface_csv else "tracker",
    )


def chain_figures(
    variant: ChainVariant, result: RigRun, *, frames: int, fps: float, run: int, backend: str
) -> ChainFigures:
    """The figures of one run from what the runner measured."""
    lines = result.records["control"]
    latencies = np.array(result.latencies_ms("control", steady=False))
    steady = np.array(result.latencies_ms("control"))
    span = (lines[-1].t_sent_ns - lines[0].t_sent_ns) / 1e9 if len(lines) > 1 else 0.0
    figures = ChainFigures(
        variant=variant,
        run=run,
        frames_sent=frames,
        commands=len(lines),
        fps=fps,
        backend=backend,
        whole_ms=latency_figures(latencies),
        steady_ms=latency_figures(steady),
        commands_per_s=(len(lines) - 1) / span if span > 0 else 0.0,
        cpu_ms=result.cpu_ms,
        peak_rss_mb=dict(result.peak_rss_mb),
        machine_busy=result.machine_busy,
        others_busy=result.others_busy,
        load=(result.load_before, result.load_after),
        gc=result.gc,
    )
    by_service = {stats.service: stats for stats in result.stats.values()}
    for name in STAGES:
        stats = by_service.get(name)
        if stats is not None:
            figures.stage_ms[name] = (stats.latency_p50_ms or 0.0, stats.latency_p99_ms or 0.0)
            figures.dropped[name] = stats.dropped
            # A process that ended before the runner read it (the sensor) said it in its stats.
            figures.peak_rss_mb.setdefault(name, stats.peak_rss_mb)
    observer = result.observer
    if observer is not None and observer.hops:
        for hop, values in observer.hop_latencies(result.steady_from).items():
            p50, p99, _ = latency_figures(values)
            figures.hops[hop] = (p50, p99)
        figures.tail = observer.tail_hops(result.steady_from)
    return figures


def bench_chain(
    chosen: Sequence[ChainVariant], *, runs: int = 1, **options: Any
) -> list[ChainFigures]:
    """Every variant ``runs`` times, interleaved (run 1 of each, then run 2 of each, …), so a
    machine whose speed drifts affects every variant alike; ``options`` as
    :func:`bench_chain_once` takes them."""
    return [
        bench_chain_once(variant, run=run, **options)
        for run in range(1, runs + 1)
        for variant in chosen
    ]
