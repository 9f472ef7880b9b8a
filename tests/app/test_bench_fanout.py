"""facesynth bench fanout: the robots' graph, how nodes share processes, the report, a real run."""

from __future__ import annotations

from pathlib import Path

import pytest

from facesynth.app.bench.fanout import (
    FanoutFigures,
    RobotFigures,
    bench_fanout_once,
    check_layout,
    fanout_graph,
    robot_groups,
    robot_profiles,
    uses_blendshapes,
)
from facesynth.app.bench.fanout_report import format_fanout, goal_line, within_goal
from facesynth.app.graph import Graph
from facesynth.app.nodes import ControlNode, TranslatorNode
from facesynth.runtime import keys
from facesynth.schemas.messages import ServiceStats


def test_the_fast_model_cycles_through_the_profiles_without_blendshapes_only() -> None:
    full, fast = robot_profiles("full"), robot_profiles("fast")
    assert {"paper16", "head16", "virtual", "arkit52", "head16_bs", "virtual_bs"} <= set(full)
    assert set(fast) == {name for name in full if not uses_blendshapes(name)}
    assert "arkit52" not in fast and "paper16" in fast


def test_each_robot_has_its_profile_and_its_own_keys(tmp_path: Path) -> None:
    graph = fanout_graph(
        8,
        video="v.mp4",
        fps=30,
        frames=10,
        model="full",
        encoding="raw",
        folder=tmp_path,
        rig="f",
        realtime=7,
    )
    translators = [n for n in graph.nodes.values() if isinstance(n, TranslatorNode)]
    controls = [n for n in graph.nodes.values() if isinstance(n, ControlNode)]
    assert len(translators) == len(controls) == 8
    assert (
        [t.robot for t in translators]
        == [c.robot for c in controls]
        == [f"r{i:02d}" for i in range(8)]
    )
    assert [t.profile for t in translators] == [c.profile for c in controls]
    assert len({t.profile for t in translators}) == len(robot_profiles("full"))
    assert len({c.driver["out"] for c in controls}) == 8
    assert all(node.realtime == 7 for node in graph.nodes.values())
    commands = {keys.stage_key("f", "servo_commands", t.robot) for t in translators}
    assert len(commands) == 8


def test_layouts_spread_the_robot_nodes_over_processes() -> None:
    assert robot_groups("processes", 3) is None
    assert robot_groups("robot", 2) == {
        "robot_r00": ["translator_r00", "control_r00"],
        "robot_r01": ["translator_r01", "control_r01"],
    }
    assert robot_groups("shared", 2) == {
        "robots0": ["translator_r00", "control_r00", "translator_r01", "control_r01"]
    }
    assert robot_groups("shared:2", 3) == {
        "robots0": ["translator_r00", "control_r00", "translator_r02", "control_r02"],
        "robots1": ["translator_r01", "control_r01"],
    }
    assert robot_groups("shared:4", 1) == {"robots0": ["translator_r00", "control_r00"]}


@pytest.mark.parametrize("layout", ["", "shared:", "shared:0", "shared:x", "threads", "robots"])
def test_unknown_layouts_are_refused(layout: str) -> None:
    with pytest.raises(ValueError, match="unknown layout"):
        check_layout(layout)


def _run(
    robots: int, layout: str, p99: float, share: float = 1.0, error: str = ""
) -> FanoutFigures:
    figures = FanoutFigures(
        robots=robots, layout=layout, frames_sent=100, steady_from=60, error=error
    )
    commands = round(100 * share)
    figures.per_robot = [
        RobotFigures(f"r{i:02d}", "paper16", commands, (p99 / 2, p99, p99 + 1))
        for i in range(robots)
    ]
    figures.overall_ms = (p99 / 2, p99, p99 + 1)
    figures.cpu_ms = {
        "sensor": 1.0,
        "points": 5.0,
        "features": 1.0,
        "router": 1.0,
        "robots0": 0.5 * robots,
    }
    return figures


def test_the_goal_is_32_robots_within_20_ms_or_where_it_stops() -> None:
    runs = [
        _run(8, "shared", 14.0),
        _run(16, "shared", 19.0),
        _run(32, "shared", 25.0),
        _run(8, "processes", 18.0),
        _run(16, "processes", 15.0, share=0.9),  # commands lost: not within the goal
        _run(32, "processes", 0.0, error="only 40 of 67 services were alive after 180 s"),
    ]
    assert [within_goal(f) for f in runs] == [True, True, False, True, False, False]
    assert goal_line(runs, "shared").endswith(
        "missed (p99 25.0 ms, 100 % of the commands); largest count within the goal: 16"
    )
    assert "missed (only 40 of 67 services" in goal_line(runs, "processes")
    assert goal_line(runs, "processes").endswith("largest count within the goal: 8")
    met = goal_line([_run(32, "shared:2", 18.5)], "shared:2")
    assert "met (p99 18.5 ms)" in met and met.endswith("goal: 32")
    text = format_fanout(runs, model="full", encoding="jpeg", mode="client", sched="normal")
    assert "did not run: only 40 of 67" in text
    assert "per robot, 32 robots, shared:" in text
    assert text.count(" r00 ") >= 1


@pytest.mark.slow
def test_two_robots_of_different_profiles_share_one_performer(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Every frame the performer's side published reached both robots: each robot's commands
    are F's frames less those its own services counted dropped, stale or rejected (their
    stats, taken after the video's end). On a loaded machine P drops frames in real time by
    design (see test_bench_chain); a robot must lose none without saying so."""
    from facesynth.app.bench import fanout
    from facesynth.app.bench.rig_run import RigRun

    runs: list[RigRun] = []
    figures_of = fanout.fanout_figures

    def keep(robots: int, layout: str, graph: Graph, result: RigRun, frames: int) -> FanoutFigures:
        runs.append(result)
        return figures_of(robots, layout, graph, result, frames)

    monkeypatch.setattr(fanout, "fanout_figures", keep)
    figures = bench_fanout_once(2, "shared", seconds=4.0, model="fast", encoding="raw")
    assert figures.error == ""
    assert [r.profile for r in figures.per_robot] == robot_profiles("fast")[:2]
    assert len({r.profile for r in figures.per_robot}) == 2
    (run,) = runs

    def stats(service: str, node: str = "") -> ServiceStats:
        (found,) = [
            s
            for key, s in run.stats.items()
            if key.startswith(f"{service}/") and key.endswith(node)
        ]
        return found

    published = stats("features").published
    assert figures.frames_sent == 120 and published >= 60, published  # the performer played
    for robot in figures.per_robot:
        translator = stats("translator", f"translator_{robot.robot}")
        control = stats("control", f"control_{robot.robot}")
        lost = sum(s.dropped + s.stale + s.rejected for s in (translator, control))
        assert robot.commands == published - lost > 0, (robot, translator, control)
        assert 0 < robot.steady_ms[0] <= robot.steady_ms[1]
    performer, robots = figures.cpu_split()
    assert performer > 0 and robots > 0
    assert set(figures.cpu_ms) == {"sensor", "points", "features", "router", "robots0"}
