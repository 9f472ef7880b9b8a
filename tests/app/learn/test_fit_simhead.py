"""Fit on the simulated head: babble it in-process (command a random pose, let it settle,
render, track with the ``full`` model, F with the head at rest as the neutral: the babbler of
facesynth.app.learn.inprocess) and fit."""

from __future__ import annotations

import msgspec
import numpy as np
import pytest

from facesynth.app.learn.fit import FitOptions, fit_learned_profile
from facesynth.app.learn.inprocess import babble_simhead
from facesynth.runtime.profiles import load_profile


@pytest.mark.slow
def test_fit_on_a_babbled_simulated_head() -> None:
    profile = load_profile("head16_hardware")
    babble = babble_simhead(profile, 160)
    learned = fit_learned_profile(
        babble, profile, FitOptions(candidates=("poly_ridge", "knn"))
    ).learned
    assert learned is not None
    report = learned.report
    # Every servo of simhead16 moves the face; 160 poses are few: a loose bound here (the
    # report of the branch gives the figures of a full babbling).
    assert len(learned.outputs) >= 12
    assert np.mean(list(report.servo_error.values())) < 0.2
    assert not any(name.startswith("head_") for name in learned.inputs)
    assert msgspec.structs.replace(profile, learned=learned).learned is learned
