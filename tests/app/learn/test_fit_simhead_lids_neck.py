"""The learner on heads with lids and with a neck: babbled in process through their hardware
profiles (every servo, the lids and the neck included), fitted, then a performer's blink drives
the lids and her head turn the neck (T with the learned profile).

The babbler is ``facesynth learn``'s view of a head without real time or a serial port
(:func:`facesynth.app.learn.inprocess.babble_simhead`: uniform random poses over every servo
of the hardware profile, rendered, tracked with the ``full`` model, F with the head at rest as
its neutral).
"""

from __future__ import annotations

import numpy as np
import pytest

from facesynth.app.learn.fit import FitOptions, fit_learned_profile
from facesynth.app.learn.inprocess import babble_simhead
from facesynth.runtime.profiles import Profile, load_profile
from facesynth.runtime.profiles.learned import shown_inputs
from facesynth.services.translator.core import Translator

#: Poses babbled a head. The margins over each bound below: 440-530 µs on the lids and 50-90 µs
#: on the neck, where 240 poses gave 395-490 µs and 48-98 µs.
POSES = 160
ZERO = np.zeros(68)


def _learned(hardware: str, head: str) -> Profile:
    profile = load_profile(hardware)
    babble = babble_simhead(profile, POSES, head=head, seed=3)
    # every servo of the hardware profile is babbled, the two new ones over their whole travel
    u = babble.normalized(profile)
    assert babble.servos == tuple(s.name for s in profile.servos)
    assert (u[:, 16:].min(axis=0) < -0.8).all() and (u[:, 16:].max(axis=0) > 0.8).all()
    return fit_learned_profile(babble, profile, FitOptions(candidates=("poly_ridge", "knn")))


def _positions(profile: Profile, raw: dict[str, float]) -> dict[str, float]:
    """T's positions (µs) for a performer's face ``raw`` (every other input at neutral)."""
    assert profile.learned is not None
    face = dict.fromkeys(profile.learned.inputs, 0.0) | raw
    return Translator(profile).positions(ZERO, named={}, raw=face)


@pytest.mark.slow
def test_a_blink_drives_the_learned_lids() -> None:
    profile = _learned("head18_lids_hardware", "simhead18_lids")
    learned = profile.learned
    assert learned is not None
    assert {"right_eyelid", "left_eyelid"} <= set(learned.outputs)
    shown = set(shown_inputs(learned))
    assert {"eyeBlinkRight", "eyeBlinkLeft", "eye_open_right", "eye_open_left"} <= shown
    rest = _positions(profile, {})
    blink = _positions(
        profile,
        {
            "eyeBlinkRight": 0.45,
            "eyeBlinkLeft": 0.45,
            "eye_open_right": -0.25,
            "eye_open_left": -0.25,
        },
    )
    for lid in ("right_eyelid", "left_eyelid"):  # a larger pulse closes the lid
        assert blink[lid] - rest[lid] > 150, (lid, rest[lid], blink[lid])
    wink = _positions(profile, {"eyeBlinkRight": 0.45, "eye_open_right": -0.25})
    assert wink["right_eyelid"] - rest["right_eyelid"] > 150
    assert wink["right_eyelid"] - wink["left_eyelid"] > 150


@pytest.mark.slow
def test_a_head_turn_drives_the_learned_neck() -> None:
    profile = _learned("head18_neck_hardware", "simhead18_neck")
    learned = profile.learned
    assert learned is not None
    assert {"neck_yaw", "neck_pitch"} <= set(learned.outputs)
    assert {"head_yaw", "head_pitch"} <= set(shown_inputs(learned))
    rest = _positions(profile, {})
    # simhead18_neck's yaw is reversed: turning toward the performer's left is a smaller pulse
    left = _positions(profile, {"head_yaw": 12.0})
    right = _positions(profile, {"head_yaw": -12.0})
    assert left["neck_yaw"] < rest["neck_yaw"] - 100 < right["neck_yaw"] - 200
    assert abs(left["neck_pitch"] - rest["neck_pitch"]) < 100
    # the tracker reads about half the pitch the head shows (tests/app/simhead): a smaller reach
    up = _positions(profile, {"head_pitch": 8.0})
    down = _positions(profile, {"head_pitch": -8.0})
    assert down["neck_pitch"] < rest["neck_pitch"] - 50 < up["neck_pitch"] - 100
