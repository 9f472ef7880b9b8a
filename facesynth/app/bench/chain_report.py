"""The printed report of ``facesynth bench chain``: each run, then the variants side by side
with the goals against them."""

from __future__ import annotations

import math
import os
from collections.abc import Sequence

from facesynth.app.bench.chain import (
    GOAL_CPU_MS,
    GOAL_P50_MS,
    GOAL_P99_MS,
    STAGES,
    STEADY_AFTER_S,
    ChainFigures,
    ChainVariant,
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
    chosen: list[ChainVariant] = []
    for figures in all_figures:
        if figures.variant not in chosen:
            chosen.append(figures.variant)
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


def format_chain_bench(all_figures: Sequence[ChainFigures]) -> str:
    """The whole report."""
    first = all_figures[0]
    head = (
        f"facesynth bench chain: sensor, points, features, translator, control as separate "
        f"processes + a router on loopback, {os.cpu_count()} cores; {first.frames_sent} frames "
        f"at {first.fps:g} fps per run, record driver"
    )
    return "\n\n".join([head, *(format_run(f) for f in all_figures), format_summary(all_figures)])
