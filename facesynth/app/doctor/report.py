"""The report of ``facesynth doctor``, pure: findings in, lines and a verdict out.

Every check family returns :class:`Finding` values: what was looked at, whether it is there
and works, whether the configured graph needs it, and what to do when it does not. A finding
the graph needs that is missing is a ``fix`` line and keeps the graph from running; one it
does not need is a ``note``; everything else is ``ok`` (or ``info``: found, nothing to judge).
"""

from __future__ import annotations

import enum
from collections.abc import Iterable, Sequence
from dataclasses import dataclass


class Status(enum.Enum):
    """How one finding reads."""

    OK = "ok"
    INFO = "info"
    NOTE = "note"
    FIX = "fix"


@dataclass(frozen=True)
class Finding:
    """One thing looked at.

    ``good`` is None for a finding with nothing to judge (a port nothing answers on, that the
    graph does not use); ``fix`` says what to do when it is not good.
    """

    family: str
    subject: str
    text: str
    good: bool | None = True
    needed: bool = False
    fix: str = ""

    @property
    def status(self) -> Status:
        """ok, info, note (missing, not needed) or fix (missing and needed)."""
        if self.good is None:
            return Status.INFO
        if self.good:
            return Status.OK
        return Status.FIX if self.needed else Status.NOTE

    def line(self, width: int = 8) -> str:
        """The finding on one line: status, family, subject, what was found, what to do."""
        text = " ".join(self.text.split())
        if self.status in (Status.FIX, Status.NOTE) and self.fix:
            text += f": {' '.join(self.fix.split())}"
        return f"{self.status.value:<4} {self.family:<{width}} {self.subject}: {text}"


def lines(findings: Iterable[Finding]) -> list[str]:
    """Every finding on its line, families aligned."""
    found = list(findings)
    width = max((len(f.family) for f in found), default=0)
    return [finding.line(width) for finding in found]


def blocking(findings: Iterable[Finding]) -> list[Finding]:
    """The findings that keep the graph from running (``fix``)."""
    return [finding for finding in findings if finding.status is Status.FIX]


def verdict(findings: Sequence[Finding], graph: str) -> str | None:
    """None when ``graph`` can run here, else the one-line reason (the error line's text)."""
    fixes = blocking(findings)
    if not fixes:
        return None
    things = ", ".join(dict.fromkeys(f"{f.family} {f.subject}" for f in fixes))
    count = "1 thing" if len(fixes) == 1 else f"{len(fixes)} things"
    return f"graph {graph} cannot run on this host: {count} to fix ({things}), said above"
