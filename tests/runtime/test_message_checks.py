"""runtime.message_checks' bound on numbers: finite and within ±limit, checked in one pass over a
list or table (the largest magnitude), and still refused at the first bad number, named as
before, whether the message was decoded or handed over within a process (:func:`codec.check`)."""

from __future__ import annotations

import math
from typing import Any

import msgspec
import numpy as np
import pytest

from facesynth.runtime import codec, message_checks
from facesynth.runtime.message_checks import MAX_COORD, MAX_PULSE_US, SMALL, MessageError
from facesynth.schemas.messages import Features, Points, PointSet, ServoCommands

ABOVE_COORD = float(np.nextafter(MAX_COORD, math.inf))
ABOVE_PULSE = float(np.nextafter(MAX_PULSE_US, math.inf))


def _points(*coords: float) -> Points:
    return Points(
        seq=1,
        t_capture_ns=1,
        t_media_ns=1,
        face=True,
        image_width=4,
        image_height=2,
        sets=[PointSet(scheme="ibug68", dims=2, coords=[0.5, 1.0, *coords, 2.0, 3.0])],
    )


def _features(value: float) -> Features:
    return Features(
        seq=1,
        t_capture_ns=1,
        t_media_ns=1,
        face=True,
        neutral_ready=True,
        distances=[0.5],
        deltas=[0.25],
        named={"brow": 0.2, "jaw_open": value, "smile": 0.1},
    )


def _commands(**positions: float) -> ServoCommands:
    return ServoCommands(
        seq=1, t_capture_ns=1, t_media_ns=1, face=True, profile="p", positions=positions
    )


def _refusals(message: Any) -> list[str]:
    """The refusal of ``message`` by both paths (decoded bytes, object in process); [] if none."""
    out = []
    for check in (
        lambda: codec.decode(codec.encode(message), type(message)),
        lambda: codec.check(msgspec.structs.replace(message), type(message)),
    ):
        try:
            check()
        except MessageError as exc:
            out.append(str(exc))
    return out


@pytest.mark.parametrize(
    "value", [MAX_COORD, -MAX_COORD, -0.0, 0.0, 1e-300], ids=["max", "min", "-0", "0", "tiny"]
)
def test_numbers_up_to_the_limit_pass(value: float) -> None:
    assert _refusals(_points(value, 0.0)) == []
    assert _refusals(_features(value)) == []


@pytest.mark.parametrize(
    ("value", "shown"),
    [
        (ABOVE_COORD, repr(ABOVE_COORD)),
        (-ABOVE_COORD, repr(-ABOVE_COORD)),
        (math.inf, "inf"),
        (-math.inf, "-inf"),
        (math.nan, "nan"),
    ],
    ids=["above", "below", "inf", "minus-inf", "nan"],
)
def test_a_number_past_the_limit_or_not_finite_is_refused_by_name(value: float, shown: str) -> None:
    coordinate = f"a coordinate of 'ibug68' is {shown}: must be a finite number within ±1e+06"
    assert _refusals(_points(value, 0.0)) == [coordinate] * 2
    feature = f"feature 'jaw_open' is {shown}: must be a finite number within ±1e+06"
    assert _refusals(_features(value)) == [feature] * 2


def test_the_first_bad_number_in_order_is_named() -> None:
    assert (
        _refusals(_points(math.nan, math.inf))
        == ["a coordinate of 'ibug68' is nan: must be a finite number within ±1e+06"] * 2
    )
    assert _refusals(_points(ABOVE_COORD, math.nan))[0].endswith(
        f"is {ABOVE_COORD!r}: must be a finite number within ±1e+06"
    )


@pytest.mark.parametrize(
    ("positions", "detail"),
    [
        ({"a": -1.0, "b": math.nan}, "position of 'a' is negative (-1.0)"),
        ({"a": math.nan, "b": -1.0}, "position of 'a' is nan"),
        ({"a": 1500.0, "b": -0.5, "c": math.inf}, "position of 'b' is negative (-0.5)"),
        ({"a": 1500.0, "b": ABOVE_PULSE}, f"position of 'b' is {ABOVE_PULSE!r}"),
        ({"a": -math.inf}, "position of 'a' is -inf"),
    ],
    ids=["negative-first", "nan-first", "negative-before-inf", "above", "minus-inf"],
)
def test_positions_are_refused_at_their_first_problem(
    positions: dict[str, float], detail: str
) -> None:
    refusals = _refusals(_commands(**positions))
    assert len(refusals) == 2 and all(detail in refusal for refusal in refusals), refusals


def test_positions_up_to_the_largest_pulse_and_negative_zero_pass() -> None:
    assert _refusals(_commands(a=MAX_PULSE_US, b=-0.0, c=0.0, d=1500.25)) == []


def test_an_infinite_limit_still_refuses_infinities_and_nan() -> None:
    within = message_checks._within  # the one-pass bound itself, for a limit no caller passes today
    assert within(np.array([1e308, -1e308]), math.inf)
    assert not within(np.array([0.0, math.inf]), math.inf)
    assert not within(np.array([math.nan, 0.0]), math.inf)
    assert not within(np.array([2.0, 0.0]), 1.0)
    assert within(np.array([1.0, -1.0]), 1.0)


@pytest.mark.parametrize(
    "size", [4, SMALL, SMALL + 2, 900], ids=["few", "small", "small+2", "many"]
)
@pytest.mark.parametrize("value", [ABOVE_COORD, -math.inf, math.nan], ids=["above", "-inf", "nan"])
def test_the_loop_for_few_numbers_and_numpy_for_many_refuse_alike(size: int, value: float) -> None:
    values = [float(i % 50) for i in range(size)]

    def points(coords: list[float]) -> Points:
        mesh = PointSet(scheme="mesh478", dims=2, coords=coords)
        return msgspec.structs.replace(_points(), sets=[mesh])

    assert _refusals(points(values)) == []
    shown = repr(value) if math.isfinite(value) else str(value)
    named = f"a coordinate of 'mesh478' is {shown}: must be a finite number within ±1e+06"
    assert _refusals(points([*values[:-1], value])) == [named] * 2  # the last one, found
    table = {f"n{i}": v for i, v in enumerate(values[: min(size, 250)])}
    feature = Features(seq=1, t_capture_ns=1, t_media_ns=1, face=True, named=table)
    assert _refusals(feature) == []
    bad = msgspec.structs.replace(feature, named={**table, "n1": value})
    assert _refusals(bad) == [f"feature 'n1' is {shown}: must be a finite number within ±1e+06"] * 2


def test_the_loop_takes_numbers_within_the_bounds_and_nothing_else() -> None:
    small_within = message_checks._small_within
    assert small_within([0, 1.0, True, -0.0, 10**5], 0.0, MAX_PULSE_US)
    assert not small_within([10**5 + 1], 0.0, MAX_PULSE_US)
    assert not small_within([1.0, math.nan], -1.0, 1.0)
    assert not small_within(["1.0"], -1.0, 1.0)  # left to numpy's path, which names it
    assert not small_within([None], -1.0, 1.0)
    assert small_within([], 0.0, 0.0)
