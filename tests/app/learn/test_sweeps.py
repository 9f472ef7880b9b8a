"""What the sweeps showed: dead channels and dead bands, from a simulated head's samples."""

from __future__ import annotations

import numpy as np

from facesynth.app.learn.plan import Plan, PlanOptions, to_pulses
from facesynth.app.learn.sweeps import sweep_report
from facesynth.runtime.profiles import Profile, load_profile
from facesynth.schemas.messages import BabbleSample


def _face(profile: Profile, u: tuple[float, ...], rng: np.random.Generator) -> dict[str, float]:
    """servo 0 moves 'brow' beyond a dead band of 0.4, servo 1 moves nothing (dead), the others
    each move their own feature; every feature has a little noise."""
    face = {"brow": 0.0, "dead": 0.0, **{f"f{i}": 0.1 * u[i] for i in range(2, len(u))}}
    face["head_pitch"] = 2.0 * u[1]  # the head pose wobbles: not a face's movement
    if abs(u[0]) > 0.4:
        face["brow"] = 0.2 * (u[0] - 0.4 * np.sign(u[0]))
    return {k: v + float(rng.normal(0, 0.001)) for k, v in face.items()}


def test_dead_channels_and_dead_bands_are_found() -> None:
    profile = load_profile("paper16")
    rng = np.random.default_rng(0)
    plan = Plan(16, PlanOptions(sweep_steps=5, neutral_every=6))
    samples = []
    for i in range(plan.sweep_poses):
        pose = plan.pose(i)
        samples.append(
            BabbleSample(
                seq=i,
                t_capture_ns=i,
                t_media_ns=i,
                profile="paper16",
                kind=pose.kind,
                commanded=to_pulses(profile, pose.u),
                features=_face(profile, pose.u, rng),
                spread={"brow": 0.001, "dead": 0.001},
            )
        )
    report = {r.servo: r for r in sweep_report(samples, profile)}
    assert set(report) == {spec.name for spec in profile.servos}
    first, second = profile.servos[0].name, profile.servos[1].name
    assert report[second].dead and [r.servo for r in report.values() if r.dead] == [second]
    assert report[first].feature == "brow"
    # steps of 0.2: 0.4 is inside the dead band, 0.6 moves the brow by 0.04
    assert (report[first].below, report[first].above) == (0.6, 0.6)
    third = report[profile.servos[2].name]
    assert third.feature == "f2" and third.below == third.above == 0.2
    assert 0.09 < third.change < 0.11


def test_no_neutral_poses_no_report() -> None:
    assert sweep_report([], load_profile("paper16")) == []
