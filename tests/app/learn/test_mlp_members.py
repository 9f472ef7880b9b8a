"""An MLP candidate of several members: their mean, exported as one MLP the board runs."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from facesynth.app.learn.models import FitOptions, fit_model, side_by_side, sklearn_predict
from facesynth.runtime.profiles.learned_models import MLP, Layer, pack
from facesynth.runtime.profiles.learned_predict import predictor


def _layers(
    rng: np.random.Generator, sizes: tuple[int, ...]
) -> list[tuple[np.ndarray, np.ndarray]]:
    return [(rng.normal(size=(a, b)), rng.normal(size=b)) for a, b in itertools.pairwise(sizes)]


def _run(layers: list[tuple[np.ndarray, np.ndarray]], x: np.ndarray) -> np.ndarray:
    model = MLP(activation="tanh", layers=[Layer(weights=pack(w), bias=pack(b)) for w, b in layers])
    return predictor(model)(x)


def test_members_side_by_side_give_their_mean() -> None:
    rng = np.random.default_rng(0)
    members = [_layers(rng, (5, 4, 3, 2)) for _ in range(3)]
    x = rng.normal(size=(20, 5))
    joined = side_by_side(members)
    assert [w.shape for w, _ in joined] == [(5, 12), (12, 9), (9, 2)]
    assert np.all(joined[1][0][:4, 3:] == 0.0)  # no member reads another's units
    expected = np.mean([_run(m, x) for m in members], axis=0)
    np.testing.assert_allclose(_run(joined, x), expected, rtol=1e-12, atol=1e-12)


def test_one_member_is_itself() -> None:
    members = [_layers(np.random.default_rng(1), (3, 2, 1))]
    assert side_by_side(members) is members[0]


def test_a_fitted_candidate_of_members_predicts_on_the_board_what_scikit_learn_does() -> None:
    rng = np.random.default_rng(3)
    x = rng.normal(size=(60, 3))
    y = np.tanh(x @ rng.normal(size=(3, 2)))
    probe = rng.normal(size=(30, 3))
    options = FitOptions(mlp_layers=(4, 3), mlp_members=2)
    fitted, model = fit_model("mlp", x, y, options)
    assert isinstance(model, MLP) and [
        np.frombuffer(layer.bias.data).size for layer in model.layers
    ] == [8, 6, 2]
    np.testing.assert_allclose(
        predictor(model)(probe), sklearn_predict(fitted, probe), rtol=1e-10, atol=1e-12
    )
    single, _ = fit_model("mlp", x, y, FitOptions(mlp_layers=(4, 3), mlp_members=1))
    assert not np.allclose(sklearn_predict(fitted, probe), sklearn_predict(single, probe))


def test_facesynth_learn_fits_with_averaged_mlps(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """`facesynth learn`'s fit asks for MLP_MEMBERS members; other fits keep one."""
    from facesynth.app.learn import cli
    from facesynth.app.learn.models import MLP_MEMBERS

    asked: list[FitOptions] = []

    class Stop(Exception):
        pass

    def fake_fit(babble: object, profile: object, options: FitOptions) -> None:
        asked.append(options)
        raise Stop

    monkeypatch.setattr(cli, "fit_learned_profile", fake_fit)
    with pytest.raises(Stop):
        cli.fit(None, None, tmp_path / "x.learned")  # type: ignore[arg-type]
    assert MLP_MEMBERS > 1 and [o.mlp_members for o in asked] == [MLP_MEMBERS]
    assert FitOptions().mlp_members == 1
