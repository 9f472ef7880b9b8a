"""The printed report of ``facesynth bench chain``: each run, then the variants side by side
with the goals against them, then the CPU budget of each stage against the figures."""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence

from facesynth.app.bench.budget import BOARD_BUDGET_MS, BUDGET_MS, CHAIN_BUDGET_MS
from facesynth.app.bench.chain import (
    BOARD,
    GOAL_CPU_MS,
    GOAL_P50_MS,
    GOAL_P99_MS,
    STAGES,
    STEADY_AFTER_S,
    ChainFigures,
)


def verdict(value: float, goal: float, unit: str = "ms") -> str:
    """``met`` or ``missed by X ms`` (``no figure`` for NaN)."""
    if math.isnan(value):
        return "no figure"
    if value <= goal:
        return "met"
    return f"missed by {value - goal:.1f} {unit}"


def machine_line(figures: ChainFigures) -> str:
    """How busy the machine was during the CPU window (so loaded runs can be told apart)."""
    return (
        f"machine during the window: {figures.machine_busy * 100:.0f} % of "
        f"{os.cpu_count()} cores busy, {figures.others_busy * 100:.0f} % by other processes; "
        f"load average {figures.load[0]:.1f} → {figures.load[1]:.1f}"
    )


def format_run(figures: ChainFigures) -> str:
    """One run: per stage latency, drops, CPU and memory; capture → command; hops."""
    nan = float("nan")
    lines = [
        f"run {figures.run} · {figures.variant.label()} · P = {figures.backend}",
        f"  {'process':<11} {'p50 ms':>8} {'p99 ms':>8} {'dropped':>8} {'CPU ms/frame':>13} "
        f"{'peak RSS MB':>12}   (latency: capture → this stage publishes)",
    ]
    for name in (*STAGES, "router"):
        p50, p99 = figures.stage_ms.get(name, (nan, nan))
        dropped = figures.dropped.get(name)
        lines.append(
            f"  {name:<11} {p50:>8.2f} {p99:>8.2f} {'' if dropped is None else dropped:>8} "
            f"{figures.cpu_ms.get(name, nan):>13.2f} {figures.peak_rss_mb.get(name, nan):>12.1f}"
        )
    for name in sorted(set(figures.cpu_ms) - {*STAGES, "router"}):
        lines.append(f"  {name:<11} {'':>8} {'':>8} {'':>8} {figures.cpu_ms[name]:>13.2f}")
    lines.append(f"  {'whole chain':<11} {'':>8} {'':>8} {'':>8} {figures.cpu_total_ms:>13.2f}")
    w50, w99, wmax = figures.whole_ms
    s50, s99, smax = figures.steady_ms
    lines.extend(
        (
            f"  capture → command at C, steady state (after {STEADY_AFTER_S:g} s): p50 {s50:.2f} "
            f"ms, p99 {s99:.2f} ms, max {smax:.2f} ms; whole run: p50 {w50:.2f}, p99 {w99:.2f}, "
            f"max {wmax:.2f}",
            f"  {figures.commands}/{figures.frames_sent} commands, "
            f"{figures.commands_per_s:.1f} commands/s",
            f"  {machine_line(figures)}",
        )
    )
    if figures.gc:
        passes = ", ".join(
            f"{name} {n} ({oldest} gen 2, longest {longest:.1f} ms)"
            for name, (n, oldest, longest) in figures.gc.items()
        )
        lines.append(f"  garbage collector after start-up (whole run): {passes}")
    if figures.hops:
        lines.append(
            f"  {'hop':<22} {'p50 ms':>8} {'p99 ms':>8}   {'median, all':>12} "
            f"{'median, slowest 1 %':>20}"
        )
        for hop, (p50, p99) in figures.hops.items():
            every, tail = figures.tail.get(hop, (nan, nan))
            lines.append(f"  {hop:<22} {p50:>8.2f} {p99:>8.2f}   {every:>12.2f} {tail:>20.2f}")
    return "\n".join(lines)


def format_summary(all_figures: Sequence[ChainFigures]) -> str:
    """The variants side by side: every run's steady p50 and p99, mean CPU, the goals."""
    chosen = list(dict.fromkeys(figures.variant for figures in all_figures))  # in run order
    width = max(len(v.label()) for v in chosen)
    lines = [
        f"side by side (steady state; each run's figure; goals: p50 ≤ {GOAL_P50_MS:g} ms and "
        f"p99 ≤ {GOAL_P99_MS:g} ms in every run, CPU ≤ {GOAL_CPU_MS:g} ms per frame, router "
        "included)",
        f"  {'variant':<{width}}  {'p50 ms':<20} {'p99 ms':<20} {'CPU ms/frame':<13} "
        f"{'others busy':<12} goals",
    ]
    for variant in chosen:
        runs = [f for f in all_figures if f.variant == variant]
        p50s = [f.steady_ms[0] for f in runs]
        p99s = [f.steady_ms[1] for f in runs]
        cpu = [f.cpu_total_ms for f in runs]
        cpu_mean = sum(cpu) / len(cpu)
        others = sum(f.others_busy for f in runs) / len(runs)
        goals = (
            f"p50 {verdict(max(p50s), GOAL_P50_MS)}; p99 {verdict(max(p99s), GOAL_P99_MS)}; "
            f"CPU {verdict(cpu_mean, GOAL_CPU_MS)}"
        )
        lines.append(
            f"  {variant.label():<{width}}  {' '.join(f'{v:.1f}' for v in p50s):<20} "
            f"{' '.join(f'{v:.1f}' for v in p99s):<20} {cpu_mean:<13.2f} "
            f"{f'{others * 100:.0f} %':<12} {goals}"
        )
    return "\n".join(lines)


def _mean(values: Sequence[float]) -> float:
    return sum(values) / len(values) if values else float("nan")


def format_budget(
    all_figures: Sequence[ChainFigures], model_ms: Mapping[tuple[str, int], float]
) -> str:
    """Each variant's CPU per frame (the mean of its runs) against the budget of each process,
    the five-process chain and the board process; ``model_ms`` (by model and threads) is what
    the tracker's model calls take, which the points stage may spend on top of its budget."""
    chosen = list(dict.fromkeys(figures.variant for figures in all_figures))  # in run order
    lines = [
        "CPU budget (ms of CPU per frame, mean of the runs; points: beyond its model calls, "
        "measured in this process on the same video at the same frame rate)"
    ]
    for variant in chosen:
        runs = [f for f in all_figures if f.variant == variant]
        cpu = {
            name: _mean([f.cpu_ms[name] for f in runs if name in f.cpu_ms])
            for name in {name for f in runs for name in f.cpu_ms}
        }
        load = ", ".join(f"{f.load[0]:.1f}→{f.load[1]:.1f}" for f in runs)
        others = _mean([f.others_busy for f in runs]) * 100
        lines.append(
            f"  {variant.label()} ({len(runs)} run{'s' if len(runs) != 1 else ''}; load "
            f"average {load}; others busy {others:.0f} %)"
        )
        lines.append(f"    {'process':<22} {'CPU ms':>8} {'budget':>8}   verdict")
        for name, budget in BUDGET_MS.items():
            if name not in cpu:
                continue
            value = cpu[name]
            label = name
            if name == "points":
                model = model_ms.get((variant.model, variant.threads), float("nan"))
                label = f"points (model {model:.2f})"
                budget = model + budget
            lines.append(f"    {label:<22} {value:>8.2f} {budget:>8.2f}   {verdict(value, budget)}")
        if BOARD in cpu:
            value = cpu[BOARD]
            lines.append(
                f"    {'F + T + C, one process':<22} {value:>8.2f} {BOARD_BUDGET_MS:>8.2f}   "
                f"{verdict(value, BOARD_BUDGET_MS)}"
            )
        else:
            total = _mean([f.cpu_total_ms for f in runs])
            lines.append(
                f"    {'five-process chain':<22} {total:>8.2f} {CHAIN_BUDGET_MS:>8.2f}   "
                f"{verdict(total, CHAIN_BUDGET_MS)}"
            )
        p50s = " ".join(f"{f.steady_ms[0]:.1f}" for f in runs)
        p99s = " ".join(f"{f.steady_ms[1]:.1f}" for f in runs)
        worst50 = max(f.steady_ms[0] for f in runs)
        worst99 = max(f.steady_ms[1] for f in runs)
        lines.append(
            f"    capture → command p50 {p50s} ms ({verdict(worst50, GOAL_P50_MS)}), p99 {p99s} "
            f"ms ({verdict(worst99, GOAL_P99_MS)})"
        )
    return "\n".join(lines)


def format_chain_bench(
    all_figures: Sequence[ChainFigures], model_ms: Mapping[tuple[str, int], float] | None = None
) -> str:
    """The whole report (with the CPU budget when ``model_ms`` is given)."""
    first = all_figures[0]
    head = (
        f"facesynth bench chain: sensor, points, features, translator, control as separate "
        f"processes + a router on loopback, {os.cpu_count()} cores; {first.frames_sent} frames "
        f"at {first.fps:g} fps per run, record driver"
    )
    parts = [head, *(format_run(f) for f in all_figures), format_summary(all_figures)]
    if model_ms is not None:
        parts.append(format_budget(all_figures, model_ms))
    return "\n\n".join(parts)
