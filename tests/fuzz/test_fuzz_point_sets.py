"""Fuzz F's reading of a points message (services/features/point_sets.py, then the processor):
every decoded message gives finite features or one FeatureError line, never a crash."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import msgspec
import pytest
from fuzzing import FUZZ, check_tally, outcome
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

pytestmark = [pytest.mark.fuzz, pytest.mark.timeout(900)]

FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "messages" / "points_face.msgpack"
SEED: dict[str, Any] = msgspec.msgpack.decode(FIXTURE.read_bytes())
SEED_BYTES = FIXTURE.read_bytes()
SCHEMES = ["ibug68", "mesh468", "mesh478", "iris10", "other"]
#: Values per point of each scheme's full set (68, 468, 478 and 10 points).
COUNTS = {"ibug68": 68, "mesh468": 468, "mesh478": 478, "iris10": N_IRIS, "other": 3}


@st.composite
def point_sets(draw: st.DrawFn) -> dict[str, Any]:
    """A set of a known scheme (or not), its dims (mostly 2 or 3), and a count of values that
    fits them, is one point short or long, or is empty."""
    scheme = draw(st.sampled_from(SCHEMES))
    dims = draw(st.sampled_from([2, 2, 3, 3, 0, 1, 4]))
    points = COUNTS[scheme] + draw(st.sampled_from([0, 0, 0, -1, 1, -COUNTS[scheme]]))
    # Spread from a drawn origin (a full mesh drawn value by value is more than hypothesis
    # draws for one case), then a few values drawn as they come.
    origin = draw(st.floats(-2000.0, 2000.0))
    spread = draw(st.sampled_from([0.0, 1e-9, 1.0, 50.0, 1e5]))
    coords = [origin + spread * ((k * 7919) % 101) / 101 for k in range(points * dims)]
    for _ in range(draw(st.integers(0, 3)) if coords else 0):
        coords[draw(st.integers(0, len(coords) - 1))] = draw(st.floats(-1e4, 1e4))
    return {"scheme": scheme, "dims": dims, "coords": coords}


@st.composite
def points_payloads(draw: st.DrawFn) -> bytes:
    """The golden points message with its sets and scores rebuilt, mutated, damaged, or random."""
    tree = dict(SEED)
    tree["sets"] = draw(st.lists(point_sets(), max_size=4))
    score = st.one_of(st.floats(0.0, 1.0), st.floats(-0.5, 1.5))
    scores = st.lists(score, min_size=52, max_size=52) | st.lists(score, min_size=51, max_size=53)
    tree["scores"] = [
        {"scheme": "blendshapes52", "values": values}
        for values in draw(st.lists(scores, max_size=1))
    ]
    return draw(
        st.one_of(
            st.just(msgspec.msgpack.encode(tree)),
            mutated(SEED, max_changes=2).map(msgspec.msgpack.encode),
            damaged(SEED_BYTES),
            st.binary(max_size=64),
        )
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
    @given(points_payloads())
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
