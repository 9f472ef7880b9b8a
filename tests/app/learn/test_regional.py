"""The region-structured inverse model (facesynth.app.learn.regional): each servo's command
from the features its region moves, found from the sweeps; the fit keeps it where it predicts
as well as the whole face, writes it as arrays, and the board runs it in numpy."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from synthetic_babble import babble_set

from facesynth.app.learn.dataset import BabbleSet
from facesynth.app.learn.fit import FitOptions, fit_learned_profile
from facesynth.app.learn.regional import fit_parts, kept, servo_inputs
from facesynth.app.learn.regions import Regions
from facesynth.runtime.feature_names import BY_NAME, NAMES
from facesynth.runtime.profiles import Profile, load_profile, save_learned_profile
from facesynth.runtime.profiles.learned import Regional, unpack
from facesynth.runtime.profiles.learned_predict import predictor

PROFILE = "head18_neck_hardware"
#: Each servo's own feature: the neck turns the head, the right eye moves the gaze, …
OWN = {"neck_yaw": "head_yaw", "neck_pitch": "head_pitch", "right_eye_x": "gaze_right_x"}
#: … and a head turn also moves the gaze reading a little (as on simhead18_neck).
NECK_INTO_GAZE = 0.15


def _head(profile: Profile) -> tuple[list[str], np.ndarray]:
    """The features and a (features, servos) weight matrix: one own feature per servo."""
    servos = [s.name for s in profile.servos]
    spare = iter(n for n in NAMES if n not in OWN.values() and not n.startswith("head_"))
    features = [OWN.get(name) or next(spare) for name in servos]
    weights = np.eye(len(servos))
    weights[features.index("gaze_right_x"), servos.index("neck_yaw")] = NECK_INTO_GAZE
    return features, weights


def _babble(profile: Profile, sweeps: bool, poses: int = 400) -> BabbleSet:
    """Neutral poses, each servo swept alone (3 steps each way, with ``sweeps``) and random
    poses of a smooth head: face = tanh(0.8 · W u) + noise."""
    features, weights = _head(profile)
    n = len(profile.servos)
    rng = np.random.default_rng(0)
    rows, kinds = [np.zeros(n) for _ in range(8)], ["neutral"] * 8
    if sweeps:
        for servo in range(n):
            for level in (-1, -2 / 3, -1 / 3, 1 / 3, 2 / 3, 1):
                rows.append(np.eye(n)[servo] * level)
                kinds.append("sweep")
    for index in range(poses):
        neutral = index % 25 == 0
        rows.append(np.zeros(n) if neutral else rng.uniform(-1.0, 1.0, n))
        kinds.append("neutral" if neutral else "random")
    u = np.array(rows)
    span = np.array([BY_NAME[name].default_max - BY_NAME[name].default_min for name in features])
    faces = (np.tanh(0.8 * u @ weights.T) + rng.normal(0.0, 0.002, (len(u), n))) * span / 2
    return babble_set(profile, u, features, faces, kinds)


OPTIONS = FitOptions(candidates=("poly_ridge",))


def test_the_neck_reads_the_head_turn_alone_and_the_gaze_never_turns_it(tmp_path: Path) -> None:
    profile = load_profile(PROFILE)
    # few poses for a whole-face model of 18 inputs: each servo's own does better by far
    fitted = fit_learned_profile(_babble(profile, sweeps=True, poses=150), profile, OPTIONS)
    path = save_learned_profile(fitted, tmp_path / "neck.learned")
    learned = load_profile(str(path)).learned
    assert learned is not None
    assert isinstance(learned.inverse, Regional)
    assert learned.report.model == "regional poly_ridge"
    assert "regional poly_ridge" in learned.report.effective_candidates
    neck = learned.outputs.index("neck_yaw")
    (part,) = [p for p in learned.inverse.parts if neck in p.outputs]
    assert [learned.inputs[i] for i in part.inputs] == ["head_yaw"]
    (line,) = [n for n in learned.report.notes if n.startswith("regional inverse kept")]
    assert "neck_yaw (1)" in line
    assert any(n.startswith("held-out face error") for n in learned.report.notes)
    # the performer looks aside without turning: the neck's command does not move
    predict = predictor(learned.inverse)
    still = np.zeros((1, len(learned.inputs)))
    aside = still.copy()
    aside[0, learned.inputs.index("gaze_right_x")] = 3.0  # three standard deviations
    assert predict(aside)[0, neck] == predict(still)[0, neck]
    turned = still.copy()
    turned[0, learned.inputs.index("head_yaw")] = 1.0
    assert predict(turned)[0, neck] > predict(still)[0, neck] + 0.3
    # the regional model is no worse on the held-out poses than the whole face
    effective = learned.report.effective_candidates
    assert effective["regional poly_ridge"] <= effective["poly_ridge"]


def test_without_sweeps_every_servo_keeps_the_whole_face() -> None:
    profile = load_profile(PROFILE)
    fitted = fit_learned_profile(_babble(profile, sweeps=False), profile, OPTIONS)
    learned = fitted.learned
    assert learned is not None
    assert not isinstance(learned.inverse, Regional)
    assert learned.report.model == "poly_ridge"
    assert "regional inverse: not compared (no servo's region known from the sweeps)" in (
        learned.report.notes
    )
    # and the option turns the comparison off
    off = fit_learned_profile(
        _babble(profile, sweeps=True),
        profile,
        FitOptions(candidates=("poly_ridge",), regional=False),
    ).learned
    assert off is not None and not isinstance(off.inverse, Regional)


def test_the_exported_parts_predict_what_the_fitted_ones_do() -> None:
    rng = np.random.default_rng(1)
    x = rng.normal(size=(200, 5))
    y = np.column_stack([np.tanh(x[:, 0] + x[:, 1]), x[:, 2] * x[:, 3], np.sin(x[:, 4]), x[:, 0]])
    parts = [((0, 1, 2, 3, 4), (0, 3)), ((2, 3), (1,)), ((4,), (2,))]
    for family in ("poly_ridge", "knn", "mlp"):
        fitted, model = fit_parts(parts, (family, FitOptions()), x, y, FitOptions())
        probe = rng.normal(size=(30, 5))
        np.testing.assert_allclose(predictor(model)(probe), fitted.predict(probe), atol=1e-9)
        assert [p.model.__class__.__name__ for p in model.parts][1:] == ["PolyRidge"] * 2
        assert np.asarray(unpack(model.parts[2].model.coef)).shape[0] == 1


def test_which_servos_read_their_region_alone() -> None:
    regions = Regions(
        servos=("a", "b", "c", "d"),
        groups=((0, 1), (2,), (3,)),
        features=(("f0",), ("f1",), ()),
        pairs=(),
        reads=(("f0", "f9"), ("f0",), ("f1", "f2"), ()),
    )
    inputs = ["f2", "f1", "f0"]
    own = servo_inputs(regions, inputs, ["a", "c", "d"])
    # f9 is not an input of the fit; d moved nothing (unknown); b is dead (no output)
    assert own == [(2,), (0, 1), ()]
    keep = kept(np.array([0.03, 0.145, np.nan]), np.array([0.045, 0.15, 0.1]), own)
    assert keep.tolist() == [True, False, False]  # a better by 0.015, c by 0.005, d has none


@pytest.mark.parametrize("missing", ["reads", "inputs"])
def test_a_region_that_moves_none_of_the_inputs_reads_the_whole_face(missing: str) -> None:
    reads = ((),) if missing == "reads" else (("f7",),)
    regions = Regions(servos=("a",), groups=((0,),), features=((),), pairs=(), reads=reads)
    assert servo_inputs(regions, ["f0", "f1"], ["a"]) == [()]
    assert not kept(np.array([0.0]), np.array([1.0]), [()]).any()
