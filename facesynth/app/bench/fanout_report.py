"""The printed report of ``facesynth bench fanout``."""

from __future__ import annotations

import math
import os
from collections.abc import Sequence

from facesynth.app.bench.chain import STEADY_AFTER_S
from facesynth.app.bench.fanout import GOAL_P99_MS, GOAL_ROBOTS, FanoutFigures

#: A run keeps up when at least this share of every robot's commands arrived.
KEEPS_UP = 0.98


def within_goal(figures: FanoutFigures) -> bool:
    """p99 (every robot's commands together) within the goal, and the commands all arrived."""
    return (
        not figures.error
        and figures.commands_share >= KEEPS_UP
        and not math.isnan(figures.overall_ms[1])
        and figures.overall_ms[1] <= GOAL_P99_MS
    )


def format_row(figures: FanoutFigures) -> str:
    """One run as a table row."""
    if figures.error:
        return f"  {figures.robots:>6}  {figures.layout:<10} did not run: {figures.error}"
    performer, robots = figures.cpu_split()
    p50, p99, _ = figures.overall_ms
    return (
        f"  {figures.robots:>6}  {figures.layout:<10} {p50:>7.2f} {p99:>7.2f} "
        f"{figures.worst_robot_p99:>10.2f} {figures.commands_share * 100:>8.1f} % "
        f"{performer:>9.2f} {robots:>8.2f} {robots / max(figures.robots, 1):>9.2f} "
        f"{figures.others_busy * 100:>6.0f} %  {'yes' if within_goal(figures) else 'no'}"
    )


def format_robots(figures: FanoutFigures) -> str:
    """Each robot of one run."""
    lines = [f"  per robot, {figures.robots} robots, {figures.layout}:"]
    for robot in figures.per_robot:
        p50, p99, worst = robot.steady_ms
        lines.append(
            f"    {robot.robot} {robot.profile:<11} {robot.commands:>4} commands  p50 {p50:6.2f}"
            f"  p99 {p99:6.2f}  max {worst:6.2f} ms"
        )
    return "\n".join(lines)


def goal_line(all_figures: Sequence[FanoutFigures], layout: str) -> str:
    """The goal against one layout's runs: met at GOAL_ROBOTS, or where it stops."""
    runs = [f for f in all_figures if f.layout == layout]
    if not runs:
        return ""
    counts = sorted({f.robots for f in runs})
    ok = [n for n in counts if all(within_goal(f) for f in runs if f.robots == n)]
    at_goal = [f for f in runs if f.robots == GOAL_ROBOTS]
    if at_goal and all(within_goal(f) for f in at_goal):
        verdict = f"met (p99 {max(f.overall_ms[1] for f in at_goal):.1f} ms)"
    elif at_goal:
        worst = at_goal[0]
        reason = worst.error or (
            f"p99 {max(f.overall_ms[1] for f in at_goal):.1f} ms, "
            f"{min(f.commands_share for f in at_goal) * 100:.0f} % of the commands"
        )
        verdict = f"missed ({reason})"
    else:
        verdict = f"not measured (counts run: {', '.join(map(str, counts))})"
    largest = max(ok) if ok else None
    return (
        f"  {layout}: {GOAL_ROBOTS} robots within p99 ≤ {GOAL_P99_MS:g} ms: {verdict}; "
        f"largest count within the goal: {largest if largest is not None else 'none'}"
    )


def format_fanout(
    all_figures: Sequence[FanoutFigures], *, model: str, encoding: str, mode: str, sched: str
) -> str:
    """The whole report."""
    first = next((f for f in all_figures if not f.error), all_figures[0])
    lines = [
        f"facesynth bench fanout: one performer (sensor, points, features) driving N robots "
        f"(a translator and a control interface each, every available profile in turn), "
        f"{mode} sessions + a router on loopback, {os.cpu_count()} cores; {first.frames_sent} "
        f"{encoding} frames at 30 fps, tracker model {model}, scheduling {sched}",
        "layout processes: each translator and control interface a process of its own; "
        "shared: all of them in one process",
        f"latency: capture → command at each robot's control interface, steady state (after "
        f"{STEADY_AFTER_S:g} s), every robot's commands together; CPU: ms per frame",
        "",
        f"  {'robots':>6}  {'layout':<10} {'p50 ms':>7} {'p99 ms':>7} {'worst p99':>10} "
        f"{'commands':>10} {'performer':>9} {'robots':>8} {'per robot':>9} {'others':>8}  "
        f"p99 ≤ {GOAL_P99_MS:g}",
    ]
    lines.extend(format_row(f) for f in all_figures)
    largest = [f for f in all_figures if not f.error]
    if largest:
        biggest = max(f.robots for f in largest)
        lines.append("")
        lines.extend(format_robots(f) for f in largest if f.robots == biggest)
    lines.extend(("", "goal:"))
    for layout in dict.fromkeys(f.layout for f in all_figures):
        lines.append(goal_line(all_figures, layout))
    return "\n".join(lines)
