"""A soak's report, pure: the figures as JSON and as the lines printed at the end.

Sections (each a key of the JSON): ``run`` (when, how long, the options, and the signal that
ended it early, if one did), ``faults`` (every
fault injected, and how many of each kind), ``commands`` (how many executed), ``rss`` (per
process: its incarnations' steps and slopes, and its RSS per hour), ``motion`` (the largest step
against its speed limit), ``stale`` (commands executed older than the profile's limit),
``gaps`` (the longest interval between commands, per fault kind) and ``exits`` (processes that
died without being killed, and how each one left at the end).
"""

from __future__ import annotations

import datetime
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from motion_check import MotionReport

from facesynth.runtime.atomic import write_atomic
from tools.soak.commands import Gap, StaleFigures
from tools.soak.rss import ProcessFigures, Slope, Step
from tools.soak.schedule import Fault

SECTIONS = ("run", "faults", "commands", "rss", "motion", "stale", "gaps", "exits")


@dataclass(frozen=True)
class Exit:
    """A process that exited: its name, pid, exit code (negative: the signal), when (wall ns),
    and the end of its log."""

    process: str
    pid: int
    code: int
    t_ns: int
    tail: str = ""


@dataclass
class SoakResult:
    """Everything a soak measured."""

    started_ns: int
    ended_ns: int
    options: Mapping[str, Any]
    faults: Sequence[Fault]
    rss: Sequence[ProcessFigures]
    motion: MotionReport
    stale: StaleFigures
    gaps: Mapping[str, Gap]
    executed: tuple[int, int]
    #: Processes that died on their own during the soak (restarted, then).
    died: Sequence[Exit] = ()
    #: How each process left when the soak stopped it (SIGTERM): name -> exit code.
    stopped: Mapping[str, int] = field(default_factory=dict)
    #: Log lines worth a look (a Python traceback, a C++ abort), per process log.
    log_findings: Mapping[str, list[str]] = field(default_factory=dict)
    #: The signal that ended the soak before its hours were up (``"SIGINT"``); ``None``: it ran
    #: its hours.
    ended_early: str | None = None


def _iso(t_ns: int) -> str:
    return datetime.datetime.fromtimestamp(t_ns / 1e9, datetime.UTC).isoformat(timespec="seconds")


def _step(step: Step) -> dict[str, float]:
    return {
        "t_s": round(step.end_s, 1),
        "before_mb": round(step.before_mb, 1),
        "after_mb": round(step.after_mb, 1),
    }


def _slope(slope: Slope | None) -> dict[str, float] | None:
    if slope is None:
        return None
    return {
        "mb_per_hour": round(slope.mb_per_hour, 2),
        "from_s": round(slope.start_s, 1),
        "over_s": round(slope.span_s, 1),
        "samples": slope.samples,
    }


def as_json(result: SoakResult) -> dict[str, Any]:
    """The report as a JSON-ready dict (every key of :data:`SECTIONS`)."""
    start = result.started_ns
    kinds: dict[str, int] = {}
    for fault in result.faults:
        kinds[fault.kind] = kinds.get(fault.kind, 0) + 1
    return {
        "run": {
            "started": _iso(start),
            "ended": _iso(result.ended_ns),
            "hours": round((result.ended_ns - start) / 3.6e12, 4),
            "ended_early": result.ended_early,
            "options": dict(result.options),
        },
        "faults": {
            "count": len(result.faults),
            "by_kind": kinds,
            "list": [
                {
                    "kind": f.kind,
                    "target": f.target,
                    "t_s": round((f.start_ns - start) / 1e9, 1),
                    "took_s": round((f.end_ns - f.start_ns) / 1e9, 2),
                    "detail": f.detail,
                }
                for f in result.faults
            ],
        },
        "commands": {"following_frames": result.executed[0], "own_moves": result.executed[1]},
        "rss": {
            p.process: {
                "steps": [_step(s) for s in p.steps],
                "slope": _slope(p.slope),
                "hours": [
                    {
                        "hour": h.hour,
                        "first_mb": round(h.first_mb, 1),
                        "last_mb": round(h.last_mb, 1),
                        "peak_mb": round(h.peak_mb, 1),
                    }
                    for h in p.hours
                ],
                "incarnations": [
                    {
                        "pid": inc.pid,
                        "from_s": round(inc.start_s, 1),
                        "to_s": round(inc.end_s, 1),
                        "first_mb": round(inc.first_mb, 1),
                        "last_mb": round(inc.last_mb, 1),
                        "peak_mb": round(inc.peak_mb, 1),
                        "steps": [_step(s) for s in inc.steps],
                        "slope": _slope(inc.slope),
                    }
                    for inc in p.incarnations
                ],
            }
            for p in result.rss
        },
        "motion": {
            "worst_ratio": round(result.motion.worst_ratio, 3),
            "worst": result.motion.worst,
            "over": len(result.motion.over),
            "over_listed": result.motion.over[:20],
            "steps": result.motion.steps,
            "sessions": result.motion.sessions,
        },
        "stale": {
            "limit_s": result.stale.limit_s,
            "fastest_s": result.stale.fastest_s,
            "checked": result.stale.checked,
            "unstamped": result.stale.unstamped,
            "count": result.stale.count,
            "oldest_s": round(result.stale.oldest_s, 3),
            "by_kind": result.stale.by_kind,
            "listed": [
                {
                    "frame": c.frame,
                    "t_s": round((c.t_sent_ns - start) / 1e9, 2),
                    "age_s": round(c.age_s, 3),
                    "after": c.after,
                }
                for c in result.stale.listed
            ],
        },
        "gaps": {
            kind: {
                "longest_s": round(gap.seconds, 3),
                "at_s": round((gap.start_ns - start) / 1e9, 1),
                "target": gap.target,
            }
            for kind, gap in sorted(result.gaps.items())
        },
        "exits": {
            "died": [
                {
                    "process": e.process,
                    "pid": e.pid,
                    "code": e.code,
                    "t_s": round((e.t_ns - start) / 1e9, 1),
                    "tail": e.tail,
                }
                for e in result.died
            ],
            "stopped": dict(result.stopped),
            "log_findings": {name: lines for name, lines in result.log_findings.items() if lines},
        },
    }


def summary(result: SoakResult) -> list[str]:
    """The lines printed at the end of a soak."""
    report = as_json(result)
    run, faults = report["run"], report["faults"]
    kinds = ", ".join(f"{kind} {n}" for kind, n in faults["by_kind"].items())
    early = f", ended early by {result.ended_early}" if result.ended_early else ""
    lines = [
        f"soak {run['started']} -> {run['ended']} ({run['hours']:.2f} h{early}): "
        f"{faults['count']} faults ({kinds}); {result.executed[0]:,} commands following frames, "
        f"{result.executed[1]:,} of C's own",
        "RSS (MB): process  first -> last (peak); steps; slope after the last step",
    ]
    for process in result.rss:
        incs = process.incarnations
        if not incs:
            lines.append(f"  {process.process:<10} no samples")
            continue
        peak = max(inc.peak_mb for inc in incs)
        steps = ", ".join(f"+{s.rise_mb:.1f} at {s.end_s / 60:.1f} min" for s in process.steps)
        fit = process.slope
        fitted = (
            f"{fit.mb_per_hour:+.2f} MB/h over {fit.span_s / 60:.0f} min"
            if fit
            else "too short to fit"
        )
        lines.append(
            f"  {process.process:<10} {incs[0].first_mb:6.1f} -> {incs[-1].last_mb:6.1f} "
            f"({peak:.1f}); {len(incs)} incarnation(s); steps: {steps or 'none'}; {fitted}"
        )
    motion = result.motion
    lines.append(
        f"largest step: {motion.worst_ratio:.2f} of its limit ({motion.worst}); "
        f"{len(motion.over)} over the limit in {motion.steps:,} steps, {motion.sessions} sessions"
    )
    stale = result.stale
    by_kind = ", ".join(f"after {k}: {n}" for k, n in stale.by_kind.items())
    fastest = f"{stale.fastest_s * 1000:.1f} ms" if stale.fastest_s is not None else "none"
    lines.append(
        f"stale commands: {stale.count} of {stale.checked:,} executed older than "
        f"{stale.limit_s:g} s from capture (fastest way through {fastest}; oldest "
        f"{stale.oldest_s:.3f} s over it){'; ' + by_kind if by_kind else ''}"
        + (f"; {stale.unstamped} without a capture stamp" if stale.unstamped else "")
    )
    lines.append(
        "longest gap between commands: "
        + (
            ", ".join(
                f"{kind} {gap.seconds * 1000:.0f} ms ({gap.target})" if gap.target else
                f"{kind} {gap.seconds * 1000:.0f} ms"
                for kind, gap in sorted(result.gaps.items())
            )
            or "none"
        )
    )  # fmt: skip
    died = ", ".join(f"{e.process} (code {e.code})" for e in result.died)
    unclean = {name: code for name, code in result.stopped.items() if code != 0}
    lines.append(
        f"died on their own: {died or 'none'}; at the SIGTERM that ended the soak: "
        + (", ".join(f"{n} exit {c}" for n, c in unclean.items()) or "every process exit 0")
    )
    for name, found in result.log_findings.items():
        if found:
            lines.append(f"  {name}: {len(found)} log line(s) worth a look, e.g. {found[0]}")
    return lines


def write(result: SoakResult, path: Path) -> Path:
    """Write the report's JSON atomically (readable by all: it holds no secret)."""
    return write_atomic(path, json.dumps(as_json(result), indent=1) + "\n", mode=0o644)
