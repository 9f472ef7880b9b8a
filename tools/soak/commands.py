"""What the executed commands of a soak show, pure: record lines and faults in, figures out.

The lines are the ``record`` driver's (one per command C executed, with ``t_capture_ns``, the
capture stamp of the frame it came from, and ``t_sent_ns``, C's wall clock when it decided it).
Commands that follow the performer carry a ``frame``; C's own moves (the return to neutral)
carry none.

- **Stale commands**: executed commands whose age from capture is over the profile's
  ``max_command_age_s``. One host stamps both times, so the age is ``t_sent - t_capture`` less
  the fastest way through seen in the soak (as C ages a command: how much later than the
  fastest way it arrived). Each is put down to a fault by the gaps' rule (:class:`Causes`),
  at its *capture*, when its way through began.
- **Gaps**: the intervals between consecutive commands that carry a frame, each put down to
  the fault that was under way, or had just ended, when it *began* (:class:`Causes`; the latest
  to begin of those), or to ``"none"`` when no fault was near: a gap of its own, the kind worth
  a look. A gap is put down to its beginning, not its end, so one that lasts until a later
  fault (a router kill that makes every stage join anew) is not filed under that fault.
  The longest per fault kind.

The largest step against its speed limit is ``tests/motion_check.py``'s (every session of the
record file, each pair of lines); :func:`motion` runs it.
"""

from __future__ import annotations

import bisect
import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from motion_check import MotionReport, check_motion

from facesynth.runtime.profiles import Profile
from facesynth.services.control.drivers.record import RecordLine
from tools.soak.schedule import Fault

#: How many stale commands a report lists (all are counted).
LISTED = 20


def motion(path: Path, profile: Profile) -> MotionReport:
    """Every step of every session of the record file against ``profile``'s speed limits
    (none when C recorded nothing: a soak ended before the chain streamed)."""
    return check_motion(path, profile) if path.exists() else MotionReport()


#: A fault may begin this long after the last command before a gap (or a stale command's
#: capture) and still have caused it: the next command was due one frame later (33 ms at
#: 30 fps, more on a loaded machine).
LEAD_NS = 500_000_000
#: A gap beginning this long after a fault ended is still put down to it (the rig settling:
#: stages reconnecting, a stage catching up); later, the stream had recovered from it.
AFTER_NS = 2_000_000_000


class Causes:
    """Which fault a gap or a stale command is put down to, by when it began (:meth:`of`): a
    gap at its last command, a stale command at its capture."""

    def __init__(self, faults: Sequence[Fault]) -> None:
        self.faults = sorted(faults, key=lambda fault: fault.start_ns)
        self.starts = [fault.start_ns for fault in self.faults]
        #: The latest end among the faults up to each one (they may overlap).
        self.reach = list(itertools.accumulate((f.end_ns for f in self.faults), max))

    def of(self, t_ns: int) -> Fault | None:
        """Of the faults under way when a gap or a stale command began at ``t_ns`` (begun at
        most :data:`LEAD_NS` later, ended at most :data:`AFTER_NS` before), the one that began
        last; ``None`` when no fault was near."""
        index = bisect.bisect_right(self.starts, t_ns + LEAD_NS) - 1
        while index >= 0 and self.reach[index] + AFTER_NS >= t_ns:
            if self.faults[index].end_ns + AFTER_NS >= t_ns:
                return self.faults[index]
            index -= 1
        return None


def _kind(fault: Fault | None) -> str:
    return fault.kind if fault is not None else "none"


@dataclass(frozen=True)
class StaleCommand:
    """An executed command older than the limit: its frame, when C decided it (wall ns), its
    age (s, over the fastest way through), and the kind of fault it is put down to
    (:class:`Causes`, at its capture; ``"none"``: no fault was near)."""

    frame: int
    t_sent_ns: int
    age_s: float
    after: str


@dataclass(frozen=True)
class StaleFigures:
    """Stale commands among the executed ones."""

    limit_s: float
    #: The fastest way from capture to command (s); ``None`` when no command had a stamp.
    fastest_s: float | None
    checked: int
    #: Executed commands without a capture stamp (not aged).
    unstamped: int
    count: int
    oldest_s: float
    by_kind: dict[str, int]
    listed: list[StaleCommand]


def stale(lines: Sequence[RecordLine], faults: Sequence[Fault], limit_s: float) -> StaleFigures:
    """The executed commands older than ``limit_s`` from capture (see the module doc)."""
    following = [line for line in lines if line.frame is not None]
    stamped = [line for line in following if line.t_capture_ns]
    latencies = [line.t_sent_ns - (line.t_capture_ns or 0) for line in stamped]
    fastest = min(latencies, default=None)
    old: list[StaleCommand] = []
    oldest = 0.0
    causes = Causes(faults)
    for line, latency in zip(stamped, latencies, strict=True):
        age_s = (latency - (fastest or 0)) / 1e9
        oldest = max(oldest, age_s)
        if age_s > limit_s:
            after = _kind(causes.of(line.t_capture_ns or 0))
            old.append(StaleCommand(line.frame or 0, line.t_sent_ns, age_s, after))
    by_kind: dict[str, int] = {}
    for command in old:
        by_kind[command.after] = by_kind.get(command.after, 0) + 1
    return StaleFigures(
        limit_s=limit_s,
        fastest_s=fastest / 1e9 if fastest is not None else None,
        checked=len(stamped),
        unstamped=len(following) - len(stamped),
        count=len(old),
        oldest_s=oldest,
        by_kind=by_kind,
        listed=old[:LISTED],
    )


@dataclass(frozen=True)
class Gap:
    """No command carrying a frame from ``start_ns`` to ``end_ns`` (wall), and the fault it
    is put down to (``kind`` ``"none"``, ``target`` empty: none was near)."""

    start_ns: int
    end_ns: int
    kind: str
    target: str

    @property
    def seconds(self) -> float:
        return (self.end_ns - self.start_ns) / 1e9


def gaps(lines: Sequence[RecordLine], faults: Sequence[Fault]) -> dict[str, Gap]:
    """The longest gap between commands carrying a frame, per fault kind it is put down to
    (:class:`Causes`; ``"none"``: no fault was near when it began)."""
    times = sorted(line.t_sent_ns for line in lines if line.frame is not None)
    causes = Causes(faults)
    longest: dict[str, Gap] = {}
    for start, end in itertools.pairwise(times):
        fault = causes.of(start)
        kind = _kind(fault)
        gap = Gap(start, end, kind, fault.target if fault else "")
        if kind not in longest or gap.seconds > longest[kind].seconds:
            longest[kind] = gap
    return longest


def executed(lines: Sequence[RecordLine]) -> tuple[int, int]:
    """How many commands C executed: (carrying a frame, its own moves)."""
    following = sum(1 for line in lines if line.frame is not None)
    return following, len(lines) - following
