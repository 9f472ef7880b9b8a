"""Checks a record file against a profile: no servo stepped faster than its ``max_speed`` allows.

Used by the fault suites (processes killed, restarted, flooded) and the separate-hosts tests.
Each pair of consecutive lines of one session is a step: ``|Δµs| <= max_speed × (Δt + slack)``
with ``Δt`` from the lines' ``t_sent_ns``, the control interface's wall clock when it decided
each step (its limits run on its monotonic clock; ``slack``, 0.2 ms, covers the two clocks'
readings being taken a moment apart). The largest step relative to its allowance is reported.
A new session (a control interface restarted on the same file) starts at neutral by itself: a
board's own limits (the firmware's per-channel rate limit, a Maestro's or SSC-32's speed) move
the servos there; those boundaries are reported separately, not counted as steps.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from pathlib import Path

from facesynth.runtime.profiles import Profile
from facesynth.services.control.drivers.record import read_sessions

SLACK_S = 0.0002


@dataclass
class MotionReport:
    """What a record file shows: steps checked, the worst one, and any over the limit."""

    steps: int = 0
    #: The largest step as a fraction of what its servo may move in its time (with the slack).
    worst_ratio: float = 0.0
    worst: str = ""
    over: list[str] = field(default_factory=list)
    sessions: int = 0
    boundary_jumps: list[str] = field(default_factory=list)

    def summary(self) -> str:
        return (
            f"{self.steps} steps in {self.sessions} sessions: the largest at "
            f"{self.worst_ratio:.2f} of what its servo may move in its time ({self.worst}; "
            f"max_speed x (interval + {SLACK_S * 1000:.1f} ms)); {len(self.over)} over the limit"
        )


def check_motion(path: Path, profile: Profile, slack_s: float = SLACK_S) -> MotionReport:
    """Every step of every session of ``path`` against ``profile``'s speed limits."""
    specs = {spec.name: spec for spec in profile.servos if spec.max_speed > 0}
    report = MotionReport()
    previous_last = None
    for session in read_sessions(path):
        report.sessions += 1
        lines = session.lines
        if previous_last is not None and lines:
            moved = {
                name: abs(lines[0].servos[name] - previous_last.servos[name])
                for name in specs
                if name in lines[0].servos and name in previous_last.servos
            }
            if any(value > 1.0 for value in moved.values()):
                jump = max(moved.values())
                report.boundary_jumps.append(f"a new session started {jump:.0f} µs away")
        for before, after in itertools.pairwise(lines):
            dt = (after.t_sent_ns - before.t_sent_ns) / 1e9
            for name, spec in specs.items():
                if name not in before.servos or name not in after.servos:
                    continue
                step = abs(after.servos[name] - before.servos[name])
                if step == 0:
                    continue
                report.steps += 1
                allowed = spec.max_speed * (max(dt, 0.0) + slack_s) + 0.002  # 0.001 µs rounding
                ratio = step / allowed
                if ratio > report.worst_ratio:
                    report.worst_ratio = ratio
                    report.worst = f"{name} {step:.1f} µs in {dt * 1000:.1f} ms"
                if step > allowed:
                    report.over.append(
                        f"{name}: {step:.1f} µs in {dt * 1000:.1f} ms (frame {after.frame}, "
                        f"limit {spec.max_speed:g} µs/s)"
                    )
        if lines:
            previous_last = lines[-1]
    return report
