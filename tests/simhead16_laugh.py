"""simhead16's profile learned from 80 babbled poses (``poly_ridge``), and her laugh (90 frames
of the sample video from frame 240): what ``bench robot``'s closed-loop and planned tests
drive, each made once per test process."""

from __future__ import annotations

import functools

from facesynth.app.bench.robot import Performance, track_performer
from facesynth.app.data import sample_video
from facesynth.app.learn.fit import FitOptions, fit_learned_profile
from facesynth.app.learn.inprocess import babble_simhead
from facesynth.runtime.profiles import Profile, load_profile

HEAD = "simhead16"


@functools.cache
def learned_simhead16() -> Profile:
    """The profile. 80 poses over 90 frames of her laugh (once 240 over
    150): the closed loop leads the open one by more on this fit (mean rho +0.060, target
    error -0.056; once +0.022, -0.011)."""
    hardware = load_profile("head16_hardware")
    babble = babble_simhead(hardware, 80, head=HEAD, frames=2)
    fitted = fit_learned_profile(babble, hardware, FitOptions(candidates=("poly_ridge",)))
    assert fitted.learned is not None and fitted.learned.plan_steps > 0
    return fitted


@functools.cache
def laughing() -> Performance:
    """Her laugh: 90 frames from frame 240."""
    return track_performer(str(sample_video()), frames=90, start=240)
