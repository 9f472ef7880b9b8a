"""Fuzz F's reading of a points message (services/features/point_sets.py, then the processor):
every decoded message gives finite features or one FeatureError line, never a crash."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import msgspec
import pytest
from fuzzing import FUZZ, TIMEOUT, check_tally, outcome
from hypothesis import given
from hypothesis import strategies as st
from mutations import damaged, mutated

from facesynth.runtime import codec
from facesynth.schemas.messages import Points
from facesynth.services.features.core import FeatureError, FeatureProcessor
from facesynth.services.features.point_sets import (
    N_IRIS,
    blendshape_scores,
    ibug_points,
    mesh_points,
    optional_points,
)

pytestmark = [pytest.mark.fuzz, TIMEOUT]

FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "messages" / "points_face.msgpack"
SEED: dict[str, Any] = msgspec.msgpack.decode(FIXTURE.read_bytes())
SEED_BYTES = FIXTURE.read_bytes()
IBUG = "ibug68"
SCHEMES = [IBUG, "mesh468", "mesh478", "iris10", "other"]
#: Values per point of each scheme's full set (68, 468, 478 and 10 points).
COUNTS = {"ibug68": 68, "mesh468": 468, "mesh478": 478, "iris10": N_IRIS, "other": 3}


#: A set's shape: mostly one F can read (dims 2 or 3; every point, or one short), else one the
#: codec or a reader refuses (dims 0, 1 or 4; empty; one point over).
_FITTING_DIMS = st.sampled_from([2, 3])
_FITTING_MISSING = st.sampled_from([0, 0, 0, 1])
_ANY_DIMS = st.sampled_from([2, 2, 3, 3, 0, 1, 4])
_ANY_COUNTS = {scheme: st.sampled_from([n, n - 1, n + 1, 0]) for scheme, n in COUNTS.items()}
_SPREADS = st.sampled_from([0.0, 1e-9, 1.0, 50.0, 1e5])
_ORIGINS = st.floats(-2000.0, 2000.0)
_CHANGED = st.integers(0, 3)
#: 0 one time in four.
_ONE_IN_FOUR = st.integers(0, 3)
_CHANGES = st.floats(-1e4, 1e4)
#: Distinct schemes (a repeated one is added below, now and then).
_SCHEME_LISTS = st.lists(st.sampled_from(SCHEMES), max_size=4, unique=True)
#: 52 blendshape scores, now and then one short or long; values in 0..1 with up to two drawn
#: from 0..1 or beyond it.
_SCORE_COUNTS = st.sampled_from([52, 52, 52, 52, 51, 53])
_SCORES = st.one_of(st.floats(0.0, 1.0), st.floats(-0.5, 1.5))
_SCORES_CHANGED = st.integers(0, 2)


@st.composite
def point_sets(draw: st.DrawFn, scheme: str) -> dict[str, Any]:
    """A set of ``scheme``, its dims and a count of values that fits them (or one point short),
    or, one time in four, a shape the codec or a reader refuses: dims 0, 1 or 4, one point
    long, or empty."""
    if draw(_ONE_IN_FOUR) == 0:
        dims = draw(_ANY_DIMS)
        points = draw(_ANY_COUNTS[scheme])
    else:
        dims = draw(_FITTING_DIMS)
        points = COUNTS[scheme] - draw(_FITTING_MISSING)
    # Spread from a drawn origin (a full mesh drawn value by value is more than hypothesis
    # draws for one case), then a few values drawn as they come.
    origin = draw(_ORIGINS)
    spread = draw(_SPREADS)
    coords = [origin + spread * ((k * 7919) % 101) / 101 for k in range(points * dims)]
    for _ in range(draw(_CHANGED) if coords else 0):
        coords[draw(st.integers(0, len(coords) - 1))] = draw(_CHANGES)
    return {"scheme": scheme, "dims": dims, "coords": coords}


@st.composite
def scores(draw: st.DrawFn) -> list[float]:
    """Blendshape scores: a drawn level's pattern, with a few values drawn as they come."""
    level = draw(st.floats(0.0, 1.0))
    values = [level * ((k * 37) % 101) / 100 for k in range(draw(_SCORE_COUNTS))]
    for _ in range(draw(_SCORES_CHANGED)):
        values[draw(st.integers(0, len(values) - 1))] = draw(_SCORES)
    return values


@st.composite
def rebuilt(draw: st.DrawFn) -> bytes:
    """The golden points message with its sets and scores rebuilt: distinct schemes (ibug68
    among them more often than not), now and then a scheme twice; no score set or one."""
    schemes = draw(_SCHEME_LISTS)
    if IBUG not in schemes and draw(st.booleans()):
        schemes.insert(0, IBUG)
    sets = [draw(point_sets(scheme)) for scheme in schemes]
    if sets and draw(_ONE_IN_FOUR) == 0:
        sets.append(sets[-1])  # the codec refuses a scheme twice
    tree = dict(SEED)
    tree["sets"] = sets
    tree["scores"] = [
        {"scheme": "blendshapes52", "values": values}
        for values in draw(st.lists(scores(), max_size=1))
    ]
    return msgspec.msgpack.encode(tree)


#: The rebuilt message (half the cases: what reaches the readers), the golden one mutated or
#: damaged, or random bytes.
points_payloads = st.one_of(
    rebuilt(),
    rebuilt(),
    rebuilt(),
    mutated(SEED, max_changes=2).map(msgspec.msgpack.encode),
    damaged(SEED_BYTES),
    st.binary(max_size=64),
)


def _read(points: Points) -> None:
    """Every reader of point_sets on its own, then the whole processor."""
    ibug = ibug_points(points)
    assert ibug.shape == (68, 2)
    mesh = mesh_points(points)
    assert mesh is None or mesh.shape == (468, 3)
    iris = optional_points(points, "iris10", N_IRIS, 2)
    assert iris is None or iris.shape == (N_IRIS, 2)
    scores = blendshape_scores(points)
    assert scores is None or (scores.min() >= 0.0 and scores.max() <= 1.0)


def test_points_give_finite_features_or_a_feature_error() -> None:
    decode_target = "codec.decode (points for F)"
    read_target = "point_sets readers"
    target = "FeatureProcessor.process"

    @FUZZ
    @given(points_payloads)
    def case(payload: bytes) -> None:
        points = outcome(decode_target, lambda: codec.decode(payload, Points), codec.MessageError)
        if points is None:
            return
        outcome(read_target, lambda: _read(points), FeatureError)
        features = outcome(target, lambda: FeatureProcessor().process(points), FeatureError)
        if features is None:
            return
        for values in (features.distances, features.deltas, features.displacements):
            assert all(math.isfinite(v) for v in values)
        assert all(math.isfinite(v) for v in features.named.values())

    case()
    check_tally(decode_target, "valid", "refused")
    check_tally(read_target, "valid", "refused", every_case=False)
    check_tally(target, "valid", "refused", every_case=False)
