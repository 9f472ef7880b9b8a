"""Safety rules on servo positions, pure.

*Travel* is how far a servo is from neutral toward one of its extremes, as a fraction:
``(p - neutral) / (max - neutral)`` above neutral, ``(neutral - p) / (neutral - min)`` below
(signed: negative below neutral). An *exclusive* rule names two or more servos and a threshold
in (0, 1]: at most one of them may be beyond ``threshold`` of its travel (in either direction)
at a time. Resolution: the servo with the largest travel keeps its position (on a tie, the one
listed first); every other servo of the rule beyond the threshold is pulled back to exactly the
threshold, on its own side of neutral. Rules are applied in profile order; pulling back only
reduces travel, so a later rule never breaks an earlier one.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

from facesynth.runtime.profiles import ExclusiveRule, ServoSpec


def travel(position: float, spec: ServoSpec) -> float:
    """Signed fraction of the way from neutral to the extreme on ``position``'s side."""
    if position >= spec.neutral_us:
        span = spec.max_us - spec.neutral_us
        return (position - spec.neutral_us) / span if span > 0 else 0.0
    span = spec.neutral_us - spec.min_us
    return -(spec.neutral_us - position) / span if span > 0 else 0.0


def at_travel(fraction: float, spec: ServoSpec) -> float:
    """The position at signed ``fraction`` of the travel (the inverse of :func:`travel`)."""
    if fraction >= 0:
        return spec.neutral_us + fraction * (spec.max_us - spec.neutral_us)
    return spec.neutral_us + fraction * (spec.neutral_us - spec.min_us)


def apply_exclusive(
    positions: Mapping[str, float],
    rules: Iterable[ExclusiveRule],
    specs: Mapping[str, ServoSpec],
) -> dict[str, float]:
    """``positions`` with every exclusive rule enforced (a new dict; the input is untouched)."""
    out = dict(positions)
    for rule in rules:
        over = []
        for order, name in enumerate(rule.servos):
            fraction = travel(out[name], specs[name])
            if abs(fraction) > rule.threshold:
                over.append((abs(fraction), -order, name, fraction))
        if len(over) < 2:
            continue
        keeper = max(over)[2]
        for _, _, name, fraction in over:
            if name != keeper:
                out[name] = at_travel(math.copysign(rule.threshold, fraction), specs[name])
    return out
