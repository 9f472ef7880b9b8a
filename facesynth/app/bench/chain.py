"""``facesynth bench chain``: the five services as separate processes on a loopback router.

Plays a video in real time through S → P → F → T → C (record driver) and prints, per stage,
capture-to-publish latency (p50/p99, from each service's own stats), the capture-to-command
latency measured at the control interface, throughput, and each process's peak memory (RSS).
"""

from __future__ import annotations

import asyncio
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from facesynth.app.data import sample_video
from facesynth.app.graph import Graph, graph_to_toml
from facesynth.app.nodes import (
    ControlNode,
    FeaturesNode,
    PointsNode,
    SensorNode,
    TranslatorNode,
    stage_of,
)
from facesynth.runtime import codec, keys
from facesynth.runtime.bus.zenoh_bus import ZenohBus, ZenohOptions
from facesynth.runtime.stats import memory_mb
from schemas.messages import ServiceStats
from services.control.drivers.record import read_record

STAGES = keys.SERVICES
#: Frames of the first seconds (start-up and F's neutral window) left out of "steady state".
STEADY_AFTER_S = 2.0


@dataclass
class ChainBench:
    """Figures of one chain benchmark run."""

    frames_sent: int
    commands: int
    seconds: float
    fps: float
    latency_ms: dict[str, tuple[float, float]] = field(default_factory=dict)
    capture_to_command_ms: tuple[float, float, float] = (0.0, 0.0, 0.0)
    peak_rss_mb: dict[str, float] = field(default_factory=dict)
    dropped: dict[str, int] = field(default_factory=dict)
    backend: str = ""
    encoding: str = "jpeg"
    steady_ms: tuple[float, float, float] = (0.0, 0.0, 0.0)
    mode: str = "client"


def _facesynth(*args: str, log: Path) -> subprocess.Popen[bytes]:
    with open(log, "wb") as out:
        return subprocess.Popen(
            [sys.executable, "-m", "facesynth", *args],
            stdout=out,
            stderr=subprocess.STDOUT,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )


def _router_locator(log: Path, proc: subprocess.Popen[bytes], timeout: float = 15.0) -> str:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        match = re.search(r"listening on (tcp/[0-9.]+:\d+)", log.read_text(errors="replace"))
        if match:
            return match.group(1)
        if proc.poll() is not None:
            break
        time.sleep(0.05)
    raise RuntimeError(f"the router did not start:\n{log.read_text(errors='replace')}")


async def _collect_stats(locator: str, rig: str, seconds: float) -> dict[str, ServiceStats]:
    bus = ZenohBus.open(ZenohOptions(mode="client", connect=[locator]))
    try:
        subscription = bus.subscribe_queued(keys.stats_pattern(rig), 512)
        latest: dict[str, ServiceStats] = {}
        deadline = time.monotonic() + seconds
        while (remaining := deadline - time.monotonic()) > 0:
            try:
                sample = await asyncio.wait_for(subscription.receive(), remaining)
            except TimeoutError:
                break
            stats = codec.decode(sample.payload, ServiceStats)
            latest[stats.service] = stats
        return latest
    finally:
        await bus.close()


def bench_graph(
    *,
    video: str,
    fps: float,
    frames: int,
    encoding: str,
    openface_csv: str | None,
    threads: int,
    record: Path,
    rig: str,
) -> Graph:
    """The benchmark's chain: the video looped in real time, tracker (or a replay), record."""
    backend: dict[str, Any] = (
        {"backend": "openface", "csv": openface_csv, "loop": True}
        if openface_csv
        else {"backend": "tracker", "threads": threads}
    )
    return Graph(
        rig=rig,
        description="facesynth bench chain",
        nodes={
            "sensor": SensorNode(
                source={"source": "video", "path": video, "loop": True, "fps": fps},
                max_frames=frames,
                encoding=encoding,  # type: ignore[arg-type]
                wait_for=["points", "features", "translator", "control"],
                wait_timeout=60.0,
            ),
            "points": PointsNode(backend=backend),
            "features": FeaturesNode(),
            "translator": TranslatorNode(),
            "control": ControlNode(driver={"driver": "record", "out": str(record)}),
        },
    )


def bench_chain(
    video: str | None = None,
    seconds: float = 15.0,
    fps: float = 30.0,
    openface_csv: str | None = None,
    encoding: str = "jpeg",
    threads: int = 1,
    mode: str = "client",
) -> ChainBench:
    """Run the benchmark and return its figures."""
    frames = max(1, int(seconds * fps))
    rig = f"bench{os.getpid()}"
    with tempfile.TemporaryDirectory(prefix="facesynth-bench-") as tmp:
        folder = Path(tmp)
        router_log = folder / "router.log"
        router = _facesynth("router", "--listen", "tcp/127.0.0.1:0", log=router_log)
        procs: dict[str, subprocess.Popen[bytes]] = {}
        try:
            locator = _router_locator(router_log, router)
            common = ["--connect", locator, "--rig", rig, "--stats-interval", "0.5", "--mode", mode]
            graph = bench_graph(
                video=video or str(sample_video()),
                fps=fps,
                frames=frames,
                encoding=encoding,
                openface_csv=openface_csv,
                threads=threads,
                record=folder / "commands.jsonl",
                rig=rig,
            )
            graph_file = folder / "bench.toml"
            graph_file.write_text(graph_to_toml(graph))
            record = folder / "commands.jsonl"
            # Downstream first, so each stage listens before its input flows.
            for name in reversed(list(graph.nodes)):
                stage = stage_of(graph.nodes[name])
                procs[name] = _facesynth(
                    stage,
                    "--graph",
                    str(graph_file),
                    "--node",
                    name,
                    *common,
                    log=folder / f"{name}.log",
                )
            started = time.monotonic()
            stats_task_result: dict[str, ServiceStats] = {}

            async def watch() -> None:
                # Listen until the sensor is done and the last commands are in.
                while procs["sensor"].poll() is None:
                    stats_task_result.update(await _collect_stats(locator, rig, 1.0))
                stats_task_result.update(await _collect_stats(locator, rig, 1.5))

            asyncio.run(watch())
            elapsed = time.monotonic() - started
            if procs["sensor"].returncode != 0:
                raise RuntimeError((folder / "sensor.log").read_text(errors="replace"))
            rss = {
                name: memory_mb(proc.pid)[1] for name, proc in procs.items() if proc.poll() is None
            }
            rss.setdefault(
                "sensor",
                stats_task_result["sensor"].peak_rss_mb
                if "sensor" in stats_task_result
                else float("nan"),
            )
            for proc in procs.values():
                if proc.poll() is None:
                    proc.send_signal(signal.SIGTERM)
            for proc in procs.values():
                proc.wait(timeout=15)
            lines = [
                line for line in read_record(record) if line.frame is not None and line.t_capture_ns
            ]
        finally:
            for proc in [*procs.values(), router]:
                if proc.poll() is None:
                    proc.kill()
                    proc.wait()
    latencies = np.array([(line.t_sent_ns - line.t_capture_ns) / 1e6 for line in lines])  # type: ignore[operator]
    span = (lines[-1].t_sent_ns - lines[0].t_sent_ns) / 1e9 if len(lines) > 1 else elapsed
    result = ChainBench(
        frames_sent=frames,
        commands=len(lines),
        seconds=span,
        fps=fps,
        peak_rss_mb=rss,
        backend="openface replay" if openface_csv else f"tracker ({threads} thread(s))",
        encoding=encoding,
        mode=mode,
    )
    if latencies.size:
        p50, p99, worst = np.percentile(latencies, [50, 99, 100])
        result.capture_to_command_ms = (float(p50), float(p99), float(worst))
        # Steady state: after the first STEADY_AFTER_S seconds (start-up, the neutral window).
        steady = latencies[int(STEADY_AFTER_S * fps) :]
        if steady.size:
            s50, s99, s_worst = np.percentile(steady, [50, 99, 100])
            result.steady_ms = (float(s50), float(s99), float(s_worst))
    for name in STAGES:
        stats = stats_task_result.get(name)
        if stats is not None:
            result.latency_ms[name] = (stats.latency_p50_ms or 0.0, stats.latency_p99_ms or 0.0)
            result.dropped[name] = stats.dropped
    return result


def format_chain_bench(result: ChainBench) -> str:
    """The figures as a printable table."""
    lines = [
        f"facesynth bench chain: 5 {result.mode} processes + router on loopback, "
        f"P = {result.backend}, "
        f"{result.frames_sent} {result.encoding} frames at {result.fps:g} fps, "
        f"{os.cpu_count()} cores",
        f"{'stage':<11} {'p50 ms':>8} {'p99 ms':>8} {'dropped':>8} {'peak RSS MB':>12}"
        "   (latency: capture → this stage publishes)",
    ]
    for name in STAGES:
        p50, p99 = result.latency_ms.get(name, (float("nan"), float("nan")))
        lines.append(
            f"{name:<11} {p50:>8.2f} {p99:>8.2f} {result.dropped.get(name, 0):>8} "
            f"{result.peak_rss_mb.get(name, float('nan')):>12.1f}"
        )
    p50, p99, worst = result.capture_to_command_ms
    lines.extend(
        (
            f"capture → command (at C): p50 {p50:.2f} ms, p99 {p99:.2f} ms, max {worst:.2f} ms; "
            f"{result.commands}/{result.frames_sent} commands, "
            f"{(result.commands - 1) / max(result.seconds, 1e-9):.1f} commands/s "
            f"(first to last command: {result.seconds:.1f} s)",
            f"capture → command, steady state (after the first {STEADY_AFTER_S:g} s): "
            f"p50 {result.steady_ms[0]:.2f} ms, p99 {result.steady_ms[1]:.2f} ms, "
            f"max {result.steady_ms[2]:.2f} ms",
        )
    )
    return "\n".join(lines)
