"""Which servos a babbling session exercised, and the fit of a session stopped before every
servo was swept: refused, or (partial) fitted with those servos kept at neutral and named as
not exercised, not dead, with the held-out error over the fitted servos only."""

from __future__ import annotations

import pytest
from synthetic_babble import DEAD, hardware, planned_babble

from facesynth.app.learn.coverage import UnsweptError, coverage
from facesynth.app.learn.fit import FitOptions, fit_learned_profile, format_report
from facesynth.app.learn.plan import Plan
from facesynth.runtime.profiles import describe_learned

QUICK = FitOptions(candidates=("poly_ridge", "knn"))


NAMES = [s.name for s in hardware().servos]
#: 40 poses: the first neutral, 24 sweep steps, a neutral, 14 sweep steps: servos 0-5 swept
#: both ways, servo 6 up only (two steps), servos 7-15 never moved.
SHORT = 40


def test_a_short_session_names_the_servos_it_never_moved() -> None:
    cover = coverage(planned_babble(SHORT), hardware())
    assert cover.not_exercised == tuple(NAMES[7:])
    assert cover.one_way == (NAMES[6],)
    assert cover.unswept == NAMES[6:]
    assert cover.describe().startswith(f"{NAMES[6]} (one way only), {NAMES[7]}, ")


def test_the_sweeps_done_leave_nothing_unswept() -> None:
    poses = Plan(16).sweep_poses
    assert coverage(planned_babble(poses), hardware()).unswept == []
    # the last servo swept up (three steps) but not yet down
    assert coverage(planned_babble(poses - 3), hardware()).one_way == (NAMES[-1],)


def test_a_session_missing_sweeps_is_not_fitted() -> None:
    with pytest.raises(UnsweptError) as caught:
        fit_learned_profile(planned_babble(SHORT), hardware(), QUICK)
    message = str(caught.value)
    assert message.startswith("10 of 16 servos not swept yet: ")
    assert "jaw" in message and "left_lower_lip" in message and NAMES[0] not in message


def test_a_partial_fit_keeps_the_unswept_servos_at_neutral_and_says_so() -> None:
    options = FitOptions(candidates=QUICK.candidates, partial=True)
    learned = fit_learned_profile(planned_babble(SHORT), hardware(), options).learned
    assert learned is not None
    report = learned.report
    assert learned.dead[-10:] == NAMES[6:]  # and any swept servo that moved nothing
    assert learned.outputs == [n for n in NAMES[:6] if n not in learned.dead]
    assert len(learned.outputs) >= 5
    assert report.not_exercised == NAMES[7:] and report.one_way == [NAMES[6]]
    # the held-out errors cover the fitted servos only
    assert set(report.servo_error) == set(report.effective_error) == set(learned.outputs)
    text = format_report(fit_learned_profile(planned_babble(SHORT), hardware(), options))
    assert f"over {len(learned.outputs)} of 16 servos" in text
    # the synthetic head's jaw moves nothing (DEAD), but this session never moved it
    assert NAMES[DEAD[1]] == "jaw"
    assert (
        "jaw                  not exercised: never moved while babbling (kept at neutral)" in text
    )
    assert "jaw                  dead" not in text
    assert f"{NAMES[6]:<20} swept one way only (kept at neutral)" in text
    assert "note: partial fit: 10 of 16 servos not swept yet" in text
    assert f"({len(learned.dead) - 10} dead, 10 not swept)" in describe_learned(learned)


def test_random_poses_exercise_every_servo_both_ways() -> None:
    """Past the sweeps, every servo has been moved both ways: the fit needs no --partial."""
    babble = planned_babble(Plan(16).sweep_poses + 60)
    profile = fit_learned_profile(babble, hardware(), QUICK)
    learned = profile.learned
    assert learned is not None
    assert learned.report.not_exercised == [] and learned.report.one_way == []
    assert learned.dead == [NAMES[i] for i in DEAD]
    text = format_report(profile)
    assert "jaw                  dead (kept at neutral)" in text and "over 14 of 16 servos" in text
