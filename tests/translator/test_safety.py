"""facesynth.services.translator.safety: travel fractions and exclusive (antagonist) rules."""

from __future__ import annotations

from typing import Any

import pytest

from facesynth.runtime.profiles import ExclusiveRule, Profile, Safety, ServoSpec
from facesynth.schemas.messages import Features
from facesynth.services.translator.core import Translator
from facesynth.services.translator.safety import apply_exclusive, at_travel, travel


def _spec(name: str = "s", **kw: Any) -> ServoSpec:
    fields: dict[str, Any] = dict(
        name=name, channel=0, min_us=1000.0, neutral_us=1500.0, max_us=2000.0, feature="jaw_open"
    )
    fields.update(kw)
    return ServoSpec(**fields)


PLAIN = _spec()
ASYM = _spec(min_us=900.0, neutral_us=1200.0, max_us=2100.0)
AT_MIN = _spec(min_us=1000.0, neutral_us=1000.0, max_us=2000.0)


@pytest.mark.parametrize(
    ("spec", "position", "fraction"),
    [
        (PLAIN, 1500.0, 0.0),
        (PLAIN, 2000.0, 1.0),
        (PLAIN, 1750.0, 0.5),
        (PLAIN, 1100.0, -0.8),
        (ASYM, 1650.0, 0.5),
        (ASYM, 1050.0, -0.5),
        (AT_MIN, 1000.0, 0.0),
        (AT_MIN, 1900.0, 0.9),
    ],
    ids=["neutral", "max", "half-up", "down", "asym-up", "asym-down", "at-min", "at-min-up"],
)
def test_travel_and_back(spec: ServoSpec, position: float, fraction: float) -> None:
    assert travel(position, spec) == pytest.approx(fraction)
    assert at_travel(fraction, spec) == pytest.approx(position)


A = _spec("raise_a", channel=0)
B = _spec("lower_a", channel=1)
C = _spec("third", channel=2, min_us=900.0, neutral_us=1200.0, max_us=2100.0)
SPECS = {spec.name: spec for spec in (A, B, C)}
PAIR = ExclusiveRule(servos=["raise_a", "lower_a"], threshold=0.8)


@pytest.mark.parametrize(
    ("rules", "positions", "expected"),
    [
        ([PAIR], {"raise_a": 1500.0, "lower_a": 1500.0}, {}),
        ([PAIR], {"raise_a": 2000.0, "lower_a": 1800.0}, {}),  # only one beyond 0.8
        ([PAIR], {"raise_a": 1900.0, "lower_a": 1900.0}, {}),  # exactly at: allowed
        ([PAIR], {"raise_a": 2000.0, "lower_a": 1950.0}, {"lower_a": 1900.0}),
        ([PAIR], {"raise_a": 1950.0, "lower_a": 2000.0}, {"raise_a": 1900.0}),
        ([PAIR], {"raise_a": 1950.0, "lower_a": 1950.0}, {"lower_a": 1900.0}),  # tie: first keeps
        ([PAIR], {"raise_a": 2000.0, "lower_a": 1020.0}, {"lower_a": 1100.0}),  # its own side
        ([PAIR], {"raise_a": 1010.0, "lower_a": 1000.0}, {"raise_a": 1100.0}),
        (
            [ExclusiveRule(servos=["raise_a", "lower_a", "third"], threshold=0.5)],
            {"raise_a": 1800.0, "lower_a": 1900.0, "third": 2100.0},
            {"raise_a": 1750.0, "lower_a": 1750.0},
        ),
        (
            [ExclusiveRule(servos=["raise_a", "lower_a"], threshold=1.0)],
            {"raise_a": 2000.0, "lower_a": 2000.0},
            {},
        ),
        (
            [PAIR, ExclusiveRule(servos=["lower_a", "third"], threshold=0.5)],
            {"raise_a": 2000.0, "lower_a": 1950.0, "third": 1800.0},
            {"lower_a": 1900.0, "third": 1650.0},
        ),
    ],
    ids=[
        "both-neutral",
        "one-beyond",
        "both-at-threshold",
        "second-pulled-back",
        "first-pulled-back",
        "tie",
        "pulled-back-below-neutral",
        "both-low",
        "three-servos",
        "threshold-1",
        "two-rules",
    ],
)
def test_exclusive_rules(
    rules: list[ExclusiveRule], positions: dict[str, float], expected: dict[str, float]
) -> None:
    given = dict(positions)
    out = apply_exclusive(positions, rules, SPECS)
    assert out == pytest.approx({**positions, **expected})
    assert positions == given  # the input is not modified
    for rule in rules:
        beyond = [n for n in rule.servos if abs(travel(out[n], SPECS[n])) > rule.threshold + 1e-9]
        assert len(beyond) <= 1


def _features(t_index: int, named: dict[str, float]) -> Features:
    return Features(
        seq=t_index,
        t_capture_ns=0,
        t_media_ns=t_index * 33_333_333,
        face=True,
        neutral_ready=True,
        named=named,
    )


def test_translator_never_commands_both_extremes() -> None:
    # Hanson-style antagonists on two servos: the brow raiser and the brow lowerer.
    profile = Profile(
        name="pair",
        servos=[
            _spec("raise_a", channel=0, feature="brow_raise_inner_right", max_speed=1500.0),
            _spec("lower_a", channel=1, feature="brow_lower_right", max_speed=3000.0),
        ],
        safety=Safety(exclusive=[PAIR]),
    )
    translator = Translator(profile)
    frames = (
        [{"brow_raise_inner_right": 1.0, "brow_lower_right": 0.0}]
        + [{"brow_raise_inner_right": 1.0, "brow_lower_right": 1.0}] * 5  # both asked at once
        + [{"brow_raise_inner_right": 0.0, "brow_lower_right": 1.0}] * 10  # swap: they cross
    )
    seen = []
    for index, named in enumerate(frames):
        out = translator.step(_features(index, named))
        seen.append(out)
        fractions = [abs(travel(out[n], SPECS[n])) for n in ("raise_a", "lower_a")]
        assert min(fractions) <= 0.8 + 1e-9, (index, out)
    assert seen[1] == pytest.approx({"raise_a": 2000.0, "lower_a": 1600.0})  # 3000 µs/s
    assert seen[5] == pytest.approx({"raise_a": 2000.0, "lower_a": 1900.0})  # held at 0.8
    # The swap: lower_a is faster and reaches its extreme while raise_a (1950) is still beyond
    # 0.8; the output rule pulls raise_a back to 1900.
    assert seen[6] == pytest.approx({"raise_a": 1900.0, "lower_a": 2000.0})
    assert seen[-1] == pytest.approx({"raise_a": 1500.0, "lower_a": 2000.0})
