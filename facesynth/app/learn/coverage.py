"""Which servos the babbling exercised: moved both ways from neutral, one way only, or never.

Pure numpy, from a :class:`~facesynth.app.learn.dataset.BabbleSet`. The plan sweeps each servo
alone, down and up, before any random pose (:mod:`facesynth.app.learn.plan`), so a session
stopped early (``--poses 40`` on sixteen servos) holds servos that never left neutral. Such a
servo is *not exercised*: nothing is known about it, which is not the same as *dead* (swept, and
the camera saw nothing move). The fit refuses a session in which some servo has not been moved
both ways (:class:`UnsweptError`) unless asked for a partial fit, which keeps those servos at
neutral and says so.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from facesynth.app.learn.dataset import BabbleSet
from facesynth.runtime.profiles import Profile

#: A command at least this far from neutral (normalized, |u|) moved the servo.
MOVED = 0.05


@dataclass(frozen=True)
class Coverage:
    """The profile's servos the babbling did not fully exercise (each list in profile order).

    Attributes:
        servos: every servo of the profile.
        not_exercised: never commanded off neutral (or not in the session at all).
        one_way: commanded to one side of neutral only (a sweep stopped halfway).
    """

    servos: tuple[str, ...]
    not_exercised: tuple[str, ...]
    one_way: tuple[str, ...]

    @property
    def unswept(self) -> list[str]:
        """The servos not yet moved both ways, in profile order."""
        missing = set(self.not_exercised) | set(self.one_way)
        return [name for name in self.servos if name in missing]

    def describe(self) -> str:
        """The unswept servos as text, e.g. ``jaw, left_eye_y (one way only)``."""
        return ", ".join(
            f"{name} (one way only)" if name in self.one_way else name for name in self.unswept
        )


class UnsweptError(ValueError):
    """A session whose babbling has not yet moved every servo both ways."""

    def __init__(self, coverage: Coverage) -> None:
        self.coverage = coverage
        unswept = coverage.unswept
        super().__init__(
            f"{len(unswept)} of {len(coverage.servos)} servos not swept yet: {coverage.describe()}"
        )


def coverage(babble: BabbleSet, profile: Profile) -> Coverage:
    """Which of ``profile``'s servos ``babble`` moved below and above neutral."""
    u = babble.normalized(profile) if len(babble) else np.zeros((0, len(babble.servos)))
    below = dict(zip(babble.servos, np.any(u <= -MOVED, axis=0).tolist(), strict=True))
    above = dict(zip(babble.servos, np.any(u >= MOVED, axis=0).tolist(), strict=True))
    names = tuple(spec.name for spec in profile.servos)
    never = tuple(n for n in names if not below.get(n, False) and not above.get(n, False))
    one_way = tuple(
        n for n in names if n not in never and not (below.get(n, False) and above.get(n, False))
    )
    return Coverage(servos=names, not_exercised=never, one_way=one_way)
