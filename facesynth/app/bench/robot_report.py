"""``facesynth bench robot``'s output: a table per head with the profiles side by side, or JSON."""

from __future__ import annotations

import math
from typing import Any

from facesynth.runtime.feature_names import NAMES

from .robot import HeadRun, RobotBench
from .robot_compare import (
    MOVED_SPAN,
    RATIO_BAND,
    REACH_FLOOR,
    REACH_RATIO,
    FeatureRow,
    Lead,
    Summary,
    lead,
)

__all__ = ["format_robot", "robot_json"]

NAME_WIDTH = 34
CELL = 20


def _cell(head: HeadRun) -> int:
    """A profile column's width: :data:`CELL`, or the longest profile name and a gap."""
    return max([CELL, *(len(run.profile) + 2 for run in head.profiles)])


def _number(value: float, digits: int = 2) -> str:
    return "-" if not math.isfinite(value) else f"{value:.{digits}f}"


def _span(value: float) -> str:
    if not math.isfinite(value):
        return "-"
    return f"{value:.1f}" if abs(value) >= 1 else f"{value:.3f}"


def _legend() -> str:
    thresholds = ", ".join(f"{value:g} {unit}" for unit, value in MOVED_SPAN.items())
    return (
        f"features the performer moves: span (p95 - p5) >= {thresholds}\n"
        f"rho: Pearson per frame; ratio: robot span / performer span (goal "
        f"{RATIO_BAND[0]}-{RATIO_BAND[1]}); reach 'no': under every profile on that head the "
        f"robot's span stays below {REACH_RATIO} of the performer's or {REACH_FLOOR} of the "
        f"unit's threshold\n"
        f"lead: mean rho / median ratio over the features the performer moves and the robot "
        f"moved while babbling (a profile learned for the head: the inputs its fit can show); "
        f"on a head not babbled here, over those it can reach; 'all': every moved feature\n"
        f"in reach: median of the robot's span / the span of her change clipped into the "
        f"robot's reach (gain 1; reach_low..reach_high of the head's learned profile, its "
        f"babbled face's 1st-99th percentile), so what the robot cannot reach is not counted "
        f"as lost ('-': no learned profile on the head)"
    )


def _lead_label(first: Lead) -> str:
    which = "babbled" if first.basis == "babbling" else "reached"
    return f"lead, {len(first.features)} moved & {which}: rho / ratio / in reach"


def _pair(figures: Lead) -> str:
    return f"{_number(figures.mean_rho)} / {_number(figures.median_ratio)}"


def _triple(figures: Lead) -> str:
    return f"{_pair(figures)} / {_number(figures.median_reach_ratio)}"


def lead_lines(head: HeadRun) -> list[str]:
    """The lines a head's table leads with: the lead figures per profile, then the same over
    every feature the performer moves (and those left out of the lead when it was babbled)."""
    width = _cell(head)
    leads = [lead(run.rows, head.babbled) for run in head.profiles]
    moved = [row.name for row in head.profiles[0].rows if row.moved]
    every = [lead(run.rows, moved) for run in head.profiles]
    lines = [
        f"  {_lead_label(leads[0]):<{NAME_WIDTH + 16}}"
        + "".join(f"{_triple(figures):<{width}}" for figures in leads),
        f"  {f'all {len(moved)} moved: rho / ratio':<{NAME_WIDTH + 16}}"
        + "".join(f"{_pair(figures):<{width}}" for figures in every),
    ]
    if head.babbled is not None:
        left = sorted(set(moved) - set(leads[0].features))
        if left:
            lines.append(f"  moved, not babbled (left out of the lead): {', '.join(left)}")
    if head.reach_from is not None:
        lines.append(f"  in reach: against the robot's reach as {head.reach_from} records it")
    return lines


def _summary_lines(head: HeadRun) -> list[str]:
    width = _cell(head)

    def row(label: str, cell: Any) -> str:
        cells = "".join(f"{cell(run.summary):<{width}}" for run in head.profiles)
        return f"  {label:<{NAME_WIDTH + 16}}{cells}"

    lagged = "".join(
        f"{f'{run.lag_frames} ({_number(run.lag_rho)})':<{width}}" for run in head.profiles
    )

    def share(summary: Summary) -> str:
        return "-" if not math.isfinite(summary.in_band) else f"{summary.in_band:.0%}"

    return [
        row("moved features (head can reach)", lambda s: f"{s.moved} ({s.reachable})"),
        row("mean rho, features it can reach", lambda s: _number(s.mean_rho)),
        row("mean rho, every moved feature", lambda s: _number(s.mean_rho_all)),
        row("median ratio, features it can reach", lambda s: _number(s.median_ratio)),
        row(f"ratio within {RATIO_BAND[0]}-{RATIO_BAND[1]}", share),
        f"  {'best lag, frames (mean rho there)':<{NAME_WIDTH + 16}}{lagged}",
    ]


def _order(rows: list[FeatureRow]) -> list[FeatureRow]:
    rank = {name: i for i, name in enumerate(NAMES)}
    return sorted(rows, key=lambda r: (not r.reachable, rank.get(r.name, len(rank))))


def format_head(head: HeadRun, frames: int) -> str:
    """One head's table: per moved feature the performer's span and, per profile, ρ and the
    amplitude ratio; then each profile's summary."""
    first = head.profiles[0].rows
    moved = _order([row for row in first if row.moved])
    table = {run.profile: {row.name: row for row in run.rows} for run in head.profiles}
    width = _cell(head)
    lines = [f"head {head.head}: {frames} frames"]
    lines.append(
        f"  {'':<{NAME_WIDTH}}{'performer':<10}{'':6}"
        + "".join(f"{run.profile:<{width}}" for run in head.profiles)
    )
    lines.extend(lead_lines(head))
    lines.append(
        f"  {'feature':<{NAME_WIDTH}}{'span':<10}{'reach':6}"
        + "".join(f"{'rho':>5} {'ratio':<{width - 6}}" for _ in head.profiles)
    )
    for row in moved:
        cells = ""
        for run in head.profiles:
            theirs = table[run.profile][row.name]
            cells += f"{_number(theirs.rho):>5} {_number(theirs.ratio):<{width - 6}}"
        reach = "yes" if row.reachable else "no"
        lines.append(f"  {row.name:<{NAME_WIDTH}}{_span(row.performer_span):<10}{reach:6}{cells}")
    still = sum(not row.moved for row in first)
    lines.append(f"  ({still} features the performer does not move are left out)")
    lines.append("  summary")
    lines.extend(_summary_lines(head))
    return "\n".join(lines)


def format_robot(result: RobotBench) -> str:
    """The benchmark as text: a legend, then one table per head."""
    lines = [
        f"performer: {result.video} ({result.frames} frames at {result.fps:.2f} fps, tracker "
        f"{result.model}, tracked in {result.performer_seconds:.1f} s)",
        f"performer's neutral (her change is read from it): {result.neutral}",
        _legend(),
    ]
    for head in result.heads:
        lines.append("")
        lines.append(format_head(head, result.frames))
        took = ", ".join(f"{run.profile} {run.seconds:.1f} s" for run in head.profiles)
        lines.append(f"  run time: {took}")
    if len(result.heads) > 1:
        lines.append("")
        lines.append("lead per head (mean rho / median ratio / in reach over the lead's features):")
        for head in result.heads:
            cells = ", ".join(
                f"{run.profile} {_triple(lead(run.rows, head.babbled))}" for run in head.profiles
            )
            lines.append(f"  {head.head}: {cells}")
    return "\n".join(lines)


def _finite(value: float) -> float | None:
    return round(value, 4) if math.isfinite(value) else None


def _summary_json(summary: Summary) -> dict[str, Any]:
    return {
        "moved": summary.moved,
        "reachable": summary.reachable,
        "mean_rho": _finite(summary.mean_rho),
        "mean_rho_all_moved": _finite(summary.mean_rho_all),
        "median_ratio": _finite(summary.median_ratio),
        "in_band": _finite(summary.in_band),
    }


def _lead_json(figures: Lead) -> dict[str, Any]:
    return {
        "basis": figures.basis,
        "features": list(figures.features),
        "mean_rho": _finite(figures.mean_rho),
        "median_ratio": _finite(figures.median_ratio),
        "in_band": _finite(figures.in_band),
        "median_reach_ratio": _finite(figures.median_reach_ratio),
    }


def _row_json(row: FeatureRow) -> dict[str, Any]:
    return {
        "feature": row.name,
        "unit": row.unit,
        "frames": row.frames,
        "moved": row.moved,
        "reachable": row.reachable,
        "performer_span": _finite(row.performer_span),
        "robot_span": _finite(row.robot_span),
        "rho": _finite(row.rho),
        "ratio": _finite(row.ratio),
        "reach_ratio": _finite(row.reach_ratio),
    }


def robot_json(result: RobotBench) -> dict[str, Any]:
    """The benchmark as plain data (``--json``; NaN as ``null``)."""
    return {
        "video": result.video,
        "frames": result.frames,
        "fps": round(result.fps, 4),
        "model": result.model,
        "moved_span": dict(MOVED_SPAN),
        "ratio_band": list(RATIO_BAND),
        "reach_ratio": REACH_RATIO,
        "reach_floor": REACH_FLOOR,
        "performer_seconds": result.performer_seconds,
        "performer_neutral": result.neutral,
        "heads": [
            {
                "head": head.head,
                "babbled": None if head.babbled is None else sorted(head.babbled),
                "reach_from": head.reach_from,
                "profiles": [
                    {
                        "profile": run.profile,
                        "seconds": run.seconds,
                        "best_lag_frames": run.lag_frames,
                        "best_lag_mean_rho": _finite(run.lag_rho),
                        "lead": _lead_json(lead(run.rows, head.babbled)),
                        "summary": _summary_json(run.summary),
                        "features": [_row_json(row) for row in run.rows],
                    }
                    for run in head.profiles
                ],
            }
            for head in result.heads
        ],
    }
