"""Babbling a simulated head in process and measuring a learned profile on poses it was not
fitted on (facesynth.app.learn.inprocess), as ``python -m facesynth.app.learn.compare`` does."""

from __future__ import annotations

import numpy as np
import pytest
from synthetic_babble import hardware

from facesynth.app.learn.adaptive import AdaptiveOptions, AdaptivePlan
from facesynth.app.learn.fit import FitOptions, fit_learned_profile
from facesynth.app.learn.inprocess import (
    FRAME_NS,
    SimBabbler,
    babble,
    held_out_error,
    uniform_poses,
)
from facesynth.app.learn.stream import StreamOptions, Trajectory
from facesynth.runtime.feature_names import NAMES


@pytest.mark.slow
def test_a_profile_fitted_in_process_is_measured_on_other_poses() -> None:
    profile = hardware()
    babbler = SimBabbler(profile, "simhead16")
    train = babble(babbler, uniform_poses(16, 80, seed=0))
    test = babble(babbler, uniform_poses(16, 25, seed=1))
    assert train.kinds.count("neutral") == 4 and np.isfinite(train.faces[:, 10]).all()
    fitted = fit_learned_profile(train, profile, FitOptions(candidates=("poly_ridge",)))
    raw, effective = held_out_error(fitted, test)
    assert 0.0 < effective <= raw < 0.35  # a random guess errs by about 1/3 of the range
    with pytest.raises(ValueError, match="not learned"):
        held_out_error(profile, test)


@pytest.mark.slow
def test_the_adaptive_plan_babbles_a_simulated_head_with_what_it_saw() -> None:
    profile = hardware()
    servos = tuple(s.name for s in profile.servos)
    plan = AdaptivePlan(servos, list(NAMES), AdaptiveOptions(sweep_steps=1, region_poses=10))
    seen: list[str] = []

    def poses():  # type: ignore[no-untyped-def]
        for index in range(plan.base.sweep_poses + 12):
            pose = plan.pose(index)
            yield pose.kind, np.array(pose.u)

    def observe(kind: str, u: np.ndarray, face: np.ndarray) -> None:
        plan.observe(kind, u, face)
        seen.append(kind)

    data = babble(SimBabbler(profile, "simhead16"), poses(), observe)
    assert len(data) == len(seen) == plan.base.sweep_poses + 12
    # the regions were found from the sweeps it saw (one step each way: coarse, but the
    # mirror-image servos that move mirror-image features show)
    assert ("right_lip_corner", "left_lip_corner") in plan.regions.pairs


@pytest.mark.slow
def test_the_stream_is_paced_as_the_babbler_paces_it() -> None:
    """No servo is asked to move faster than the pace of its profile speed, frame to frame;
    a slower pace keeps the commands further behind the trajectory, and each frame's pulses
    are those in force when it was taken (the head's own channels)."""
    profile = hardware()
    trajectory = Trajectory(16, 0, StreamOptions(max_hz=3.0, min_hz=1.0, amplitude=0.5))
    speeds = np.array([s.max_speed for s in profile.servos])
    frame_s = FRAME_NS / 1e9
    behind = {}
    for pace in (0.8, 0.2):
        babbler = SimBabbler(profile, "simhead16")
        times, pulses, faces = babbler.stream(trajectory, 1.0, every=1, pace=pace)
        assert len(times) == len(pulses) == len(faces) == 30
        steps = np.abs(np.diff(pulses, axis=0))
        assert (steps <= pace * speeds * frame_s + 1e-6).all()
        assert (steps >= pace * speeds * frame_s - 1e-6).any()  # the pace bound this stream
        goals = np.array([babbler.pulses(trajectory.at(k * frame_s)) for k in range(30)])
        behind[pace] = float(np.abs(goals - pulses).mean())
        assert np.isfinite(faces[:, 10]).all()  # the face seen throughout
    assert behind[0.2] > behind[0.8] > 0
