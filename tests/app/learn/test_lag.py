"""The head's response lag measured from its transitions (facesynth/app/learn/lag.py): a known
lag is recovered from constructed step responses, a face that barely moves says nothing, a
simulated head's servos are probed (facesynth/app/learn/inprocess.py), and the fit reports the
lag without leading T by it."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from synthetic_babble import DEAD, hardware, synthetic_babble

from facesynth.app.learn.fit import FitOptions, fit_learned_profile
from facesynth.app.learn.inprocess import SimBabbler, hardware_for, probe_lags
from facesynth.app.learn.lag import (
    MAX_LEAD_S,
    Transition,
    fitted_lead,
    lag_notes,
    servo_lags,
    transition_lag,
)
from facesynth.app.simhead import load_head
from facesynth.runtime.profiles import load_profile, save_learned_profile
from facesynth.services.translator.core import Translator

FRAME_S = 1 / 30
TIMES = np.arange(40) * FRAME_S
#: How the face moves: two features one way, one the other, one not at all.
CHANGE = np.array([0.4, 0.2, -0.3, 0.0])


def step_response(
    tau_s: float, dead_s: float = 0.0, noise: float = 0.0, seed: int = 0, servo: str = "jaw"
) -> Transition:
    """A step of the command at t = 0 followed by a face lagging it by a dead time ``dead_s``
    and a first-order lag ``tau_s``, each frame's features with white noise."""
    after = np.maximum(TIMES - dead_s, 0.0)
    progress = np.where(dead_s <= TIMES, 1.0 - np.exp(-after / tau_s), 0.0)
    before = np.array([0.1, 0.0, 0.2, 0.05])
    rng = np.random.default_rng(seed)
    faces = before + progress[:, None] * CHANGE + rng.normal(0.0, noise, (len(TIMES), 4))
    return Transition(servo, TIMES, np.ones(len(TIMES)), faces, before, before + CHANGE)


@pytest.mark.parametrize(("tau_s", "dead_s"), [(0.03, 0.0), (0.08, 0.0), (0.05, 2 * FRAME_S)])
def test_a_known_lag_is_recovered_from_a_step(tau_s: float, dead_s: float) -> None:
    """A first-order lag's mean delay is its time constant, a dead time adds to it (within
    the frames' trapezoids, which overstate a lag of one frame by 3 ms at 30 frames a second)."""
    assert transition_lag(step_response(tau_s, dead_s)) == pytest.approx(tau_s + dead_s, abs=4e-3)


def test_a_ramped_command_counts_from_the_ramp_not_from_its_start() -> None:
    """A command paced over 0.2 s and a face that follows the ramp 0.06 s late: the lag is
    0.06 s, not the ramp's own time."""
    command = np.clip(TIMES / 0.2, 0.0, 1.0)
    face = np.clip((TIMES - 0.06) / 0.2, 0.0, 1.0)
    before = np.zeros(4)
    transition = Transition("jaw", TIMES, command, face[:, None] * CHANGE, before, CHANGE)
    assert transition_lag(transition) == pytest.approx(0.06, abs=1e-9)


def test_noise_and_missing_frames_move_the_lag_little() -> None:
    noisy = step_response(0.08, noise=0.01)
    faces = noisy.faces.copy()
    faces[[3, 11], 2] = np.nan  # the tracker lost a feature on two frames
    lag = transition_lag(dataclasses.replace(noisy, faces=faces))
    assert lag == pytest.approx(0.08, abs=0.01)


def test_a_face_that_barely_moves_gives_no_lag() -> None:
    still = step_response(0.08)
    barely = dataclasses.replace(still, after=still.before + 0.01 * CHANGE)
    assert transition_lag(barely) is None
    assert servo_lags([barely]) == {}


def test_per_servo_lags_are_medians_and_the_lead_is_their_median_within_bounds() -> None:
    transitions = [
        step_response(0.03, servo="eye", seed=1),
        step_response(0.05, servo="eye", seed=2),
        step_response(0.04, servo="eye", seed=3),
        step_response(0.10, servo="jaw"),
        step_response(0.12, servo="cheek"),
    ]
    lags = servo_lags(transitions)
    assert sorted(lags) == ["cheek", "eye", "jaw"]
    assert lags["eye"] == pytest.approx(0.04, abs=4e-3)
    assert fitted_lead(lags) == pytest.approx(0.10, abs=2e-3)
    assert fitted_lead({"jaw": 0.5}) == MAX_LEAD_S
    assert fitted_lead({"jaw": -0.01}) == 0.0
    assert fitted_lead({}) == 0.0
    assert "lead_s 0.1 would lead by it" in lag_notes({"jaw": 0.1})[0]
    assert lag_notes({}) == []


def test_the_fit_reports_the_lag_and_leaves_t_unled(tmp_path: Path) -> None:
    """Measured, a lead learned from the lag did not raise the likeness on every head
    (docs/learning.md): the fit says the lag and the lead it suggests, and writes lead_s 0."""
    babble = synthetic_babble(300)
    servos = [spec.name for spec in hardware().servos]
    lags = {  # the dead servos' lags would move the median
        name: 0.19 if index in DEAD else 0.05 + 0.01 * (index % 2)
        for index, name in enumerate(servos)
    }
    options = FitOptions(candidates=("poly_ridge",))
    fitted = fit_learned_profile(dataclasses.replace(babble, lags=lags), hardware(), options)
    learned = fitted.learned
    assert learned is not None and learned.retarget is not None
    live = fitted_lead({name: lags[name] for name in learned.outputs})  # dead servos do not count
    (note,) = [note for note in learned.report.notes if note.startswith("response lag")]
    assert f"lead_s {live:g} would lead by it" in note and live == 0.05 != fitted_lead(lags)
    loaded = load_profile(str(save_learned_profile(fitted, tmp_path / "head.learned")))
    assert loaded.learned is not None and loaded.learned.retarget is not None
    assert loaded.learned.retarget.lead_s == 0.0
    targets = Translator(loaded)._learned
    assert targets is not None and targets.lead is None
    unmeasured = fit_learned_profile(babble, hardware(), options).learned
    assert unmeasured is not None
    assert not any(note.startswith("response lag") for note in unmeasured.report.notes)


def test_a_simulated_heads_lag_is_probed_per_servo() -> None:
    """On simhead16 the eye (skin lag 0.02 s, slew 5,000 µs/s) follows sooner than the jaw
    (0.1 s, 2,000 µs/s); a step of half the travel adds the slew's own time to both."""
    hardware_profile = hardware_for(load_head("simhead16"))
    babbler = SimBabbler(hardware_profile, "simhead16")
    lags = probe_lags(babbler, servos=["right_eye_x", "jaw"])
    assert sorted(lags) == ["jaw", "right_eye_x"]
    assert 0.02 < lags["right_eye_x"] < 0.06 < 0.1 < lags["jaw"] < MAX_LEAD_S
