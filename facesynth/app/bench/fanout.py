"""``facesynth bench fanout``: one performer driving many robots.

One sensor, one point streamer and one feature processor; then, per robot, a translator and a
control interface (record driver) with that robot's profile, the shipped profiles in turn, on
the robot's own command keys (``…/servo_commands/<robot>``, ``…/servo_state/<robot>``: see
:mod:`facesynth.runtime.keys`). The robots' nodes are spread over processes in the layouts
asked for (:func:`robot_groups`), compared side by side; a process running several nodes is a
``facesynth run`` of a graph without a sensor (a robot host serving several robots).

For each number of robots it reports capture → command p50/p99 per robot and over every robot's
commands together, the commands that arrived, and CPU per frame: the performer's side (sensor,
points, features, router) and the robots'.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from facesynth.app.bench.chain import READERS, STEADY_AFTER_S, latency_figures
from facesynth.app.bench.rig_run import RigRun, RunOptions, run_graph
from facesynth.app.data import sample_video
from facesynth.app.graph import Graph
from facesynth.app.nodes import ControlNode, FeaturesNode, PointsNode, SensorNode, TranslatorNode
from facesynth.runtime.feature_names import BLENDSHAPE_NAMES
from facesynth.runtime.profiles import available_profiles, load_profile

#: The goal: this many robots at capture → command p99 within GOAL_P99_MS on 2 cores.
GOAL_ROBOTS = 32
GOAL_P99_MS = 20.0
#: How robots' nodes are spread over processes (see :func:`robot_groups`).
LAYOUTS = ("processes", "robot", "shared", "shared:2")


def check_layout(layout: str) -> str:
    """``layout`` if it is one of :data:`LAYOUTS` or ``shared:K`` (K ≥ 1), else ValueError."""
    name, _, count = layout.partition(":")
    if layout in ("processes", "robot", "shared") or (
        name == "shared" and count.isdigit() and int(count) >= 1
    ):
        return layout
    raise ValueError(f"unknown layout {layout!r} (use processes, robot, shared or shared:K)")


def robot_groups(layout: str, robots: int) -> dict[str, list[str]] | None:
    """The processes of a layout, by name, and the robot nodes each runs (``None``: one
    process per node): ``processes`` gives every translator and control interface a process;
    ``robot`` one process per robot (its translator and control interface, as on a robot's
    own controller host); ``shared`` one process for every robot; ``shared:K`` K processes,
    the robots dealt out in turn."""
    check_layout(layout)
    if layout == "processes" or robots == 0:
        return None
    names = [robot_name(i) for i in range(robots)]
    if layout == "robot":
        return {f"robot_{r}": [f"translator_{r}", f"control_{r}"] for r in names}
    count = 1 if layout == "shared" else int(layout.partition(":")[2])
    count = min(count, robots)
    return {
        f"robots{k}": [n for r in names[k::count] for n in (f"translator_{r}", f"control_{r}")]
        for k in range(count)
    }


def uses_blendshapes(name: str) -> bool:
    """Whether a profile is driven by blendshapes (which only the ``full`` tracker gives)."""
    profile = load_profile(name)
    return bool({n for spec in profile.servos for n in spec.weights() or {}} & BLENDSHAPE_NAMES)


def robot_profiles(model: str) -> list[str]:
    """The shipped profiles a fan-out cycles through (those without blendshapes for ``fast``)."""
    names = available_profiles()
    if model != "full":
        names = [name for name in names if not uses_blendshapes(name)]
    return names


def robot_name(index: int) -> str:
    """``r00``, ``r01``, …"""
    return f"r{index:02d}"


def fanout_graph(
    robots: int,
    *,
    video: str,
    fps: float,
    frames: int,
    model: str,
    encoding: str,
    folder: Path,
    rig: str,
    realtime: int | None = None,
) -> Graph:
    """The performer's chain and ``robots`` robots (a translator and a control node each)."""
    profiles = robot_profiles(model)
    nodes: dict[str, object] = {
        "sensor": SensorNode(
            source={"source": "video", "path": video, "loop": True, "fps": fps},
            max_frames=frames,
            encoding=encoding,  # type: ignore[arg-type]
            wait_for=list(READERS),
            wait_timeout=60.0,
            realtime=realtime,
        ),
        "points": PointsNode(backend={"backend": "tracker", "model": model}, realtime=realtime),
        "features": FeaturesNode(realtime=realtime),
    }
    for index in range(robots):
        robot, profile = robot_name(index), profiles[index % len(profiles)]
        nodes[f"translator_{robot}"] = TranslatorNode(
            profile=profile, robot=robot, realtime=realtime
        )
        nodes[f"control_{robot}"] = ControlNode(
            profile=profile,
            robot=robot,
            driver={"driver": "record", "out": str(folder / f"{robot}.jsonl")},
            realtime=realtime,
        )
    return Graph(rig=rig, description="facesynth bench fanout", nodes=nodes)  # type: ignore[arg-type]


@dataclass
class RobotFigures:
    """One robot's commands in one run."""

    robot: str
    profile: str
    commands: int
    steady_ms: tuple[float, float, float]


@dataclass
class FanoutFigures:
    """One run with ``robots`` robots laid out as ``layout``."""

    robots: int
    layout: str
    frames_sent: int
    steady_from: int
    per_robot: list[RobotFigures] = field(default_factory=list)
    #: Every robot's steady-state commands together: p50, p99, max.
    overall_ms: tuple[float, float, float] = (float("nan"), float("nan"), float("nan"))
    cpu_ms: dict[str, float] = field(default_factory=dict)
    machine_busy: float = float("nan")
    others_busy: float = float("nan")
    error: str = ""

    @property
    def worst_robot_p99(self) -> float:
        """The largest p99 of any robot."""
        values = [r.steady_ms[1] for r in self.per_robot if not np.isnan(r.steady_ms[1])]
        return max(values) if values else float("nan")

    @property
    def commands_share(self) -> float:
        """Commands applied over commands expected (every robot, every frame)."""
        expected = self.robots * self.frames_sent
        return sum(r.commands for r in self.per_robot) / expected if expected else 0.0

    def cpu_split(self) -> tuple[float, float]:
        """CPU ms per frame of the performer's side (S, P, F, router) and of all the robots."""
        performer = sum(self.cpu_ms.get(n, 0.0) for n in ("sensor", "points", "features", "router"))
        return performer, sum(self.cpu_ms.values()) - performer


def fanout_figures(
    robots: int, layout: str, graph: Graph, result: RigRun, frames: int
) -> FanoutFigures:
    """The figures of one run from what the runner measured."""
    figures = FanoutFigures(
        robots=robots,
        layout=layout,
        frames_sent=frames,
        steady_from=result.steady_from,
        cpu_ms=result.cpu_ms,
        machine_busy=result.machine_busy,
        others_busy=result.others_busy,
    )
    pooled = []
    for index in range(robots):
        robot = robot_name(index)
        node = graph.nodes[f"control_{robot}"]
        assert isinstance(node, ControlNode)
        commands = len(result.records.get(f"control_{robot}", []))
        steady = np.array(result.latencies_ms(f"control_{robot}"))
        pooled.append(steady)
        figures.per_robot.append(
            RobotFigures(robot, str(node.profile), commands, latency_figures(steady))
        )
    figures.overall_ms = latency_figures(np.concatenate(pooled) if pooled else np.array([]))
    return figures


def bench_fanout_once(
    robots: int,
    layout: str,
    *,
    video: str | None = None,
    seconds: float = 10.0,
    fps: float = 30.0,
    model: str = "full",
    encoding: str = "jpeg",
    mode: str = "client",
    realtime: int | None = None,
) -> FanoutFigures:
    """One run with ``robots`` robots laid out as ``layout`` (see :func:`robot_groups`)."""
    frames = max(1, int(seconds * fps))
    with tempfile.TemporaryDirectory(prefix="facesynth-fanout-") as tmp:
        graph = fanout_graph(
            robots,
            video=video or str(sample_video()),
            fps=fps,
            frames=frames,
            model=model,
            encoding=encoding,
            folder=Path(tmp),
            rig=f"fanout{os.getpid()}",
            realtime=realtime,
        )
        options = RunOptions(
            frames=frames,
            fps=fps,
            mode=mode,
            steady_after_s=STEADY_AFTER_S,
            groups=robot_groups(layout, robots),
            router_args=["--realtime", str(realtime)] if realtime else [],
            progress_robot=robot_name(0),
        )
        result = run_graph(graph, options)
        return fanout_figures(robots, layout, graph, result, frames)


def bench_fanout(
    counts: Sequence[int],
    layouts: Sequence[str] = ("processes", "shared"),
    *,
    runs: int = 1,
    **options: object,
) -> list[FanoutFigures]:
    """Every robot count with every layout, ``runs`` times (interleaved). A count that cannot
    run (its processes fail or never start) is reported with its error, and larger counts of the
    same layout are still tried."""
    out = []
    for _ in range(runs):
        for count in counts:
            for layout in layouts:
                try:
                    out.append(bench_fanout_once(count, layout, **options))  # type: ignore[arg-type]
                except RuntimeError as exc:
                    out.append(
                        FanoutFigures(
                            robots=count,
                            layout=layout,
                            frames_sent=0,
                            steady_from=0,
                            error=str(exc).splitlines()[0][:200],
                        )
                    )
    return out
