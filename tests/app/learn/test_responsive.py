"""Responsive ranges (facesynth.app.learn.responsive): slack sides and saturation found from
the sweeps, never a cut where the face moves; the fit stores them and reports the effective
held-out error; T stays inside them."""

from __future__ import annotations

import numpy as np
import pytest
from synthetic_babble import DEAD, SyntheticHead, hardware, synthetic_babble

from facesynth.app.learn.fit import FitOptions, fit_learned_profile, format_report
from facesynth.app.learn.responsive import clip_commands, responsive_range
from facesynth.runtime.profiles import describe_learned
from facesynth.runtime.profiles.learned import command_range
from facesynth.services.translator.learned import LearnedTargets

#: Servos of the synthetic head that move the face one way only (servo → the side that moves),
#: and one that stops changing it (both ways) beyond |u| = 0.5. (Sweep rows 25 and 50, servos
#: 6 and 12, fall on neutral checks; 5 and 11 are dead.)
ONE_SIDED = {7: -1, 14: 1}
SATURATED = {8: 0.5}


def _head() -> SyntheticHead:
    return SyntheticHead(one_sided=ONE_SIDED, saturation=SATURATED)


def _ranges(babble):  # type: ignore[no-untyped-def]
    u = babble.normalized(hardware())
    faces = np.nan_to_num(babble.faces[:, :40])
    rest = np.median(faces[np.asarray(babble.kinds) == "neutral"], axis=0)
    return responsive_range(faces - rest, u, np.asarray(babble.kinds))


def test_slack_sides_and_saturation_are_found_and_nothing_else_is_cut() -> None:
    low, high = _ranges(synthetic_babble(400, head=_head()))
    assert (low[7], high[7]) == (-1.0, 0.0)  # moves the face down only
    assert (low[14], high[14]) == (0.0, 1.0)  # up only
    assert (low[8], high[8]) == (-0.5, 0.5)  # the face stops changing beyond 0.5
    others = [s for s in range(16) if s not in (7, 8, 14)]
    assert np.all(low[others] == -1.0) and np.all(high[others] == 1.0)  # dead ones included


def test_an_ordinary_head_keeps_every_servos_whole_travel() -> None:
    low, high = _ranges(synthetic_babble(400))
    assert np.all(low == -1.0) and np.all(high == 1.0)


def test_without_neutral_samples_or_sweeps_nothing_is_cut() -> None:
    rng = np.random.default_rng(0)
    u = rng.uniform(-1, 1, (50, 3))
    t = np.column_stack([np.maximum(u[:, 0], 0), u[:, 1], u[:, 2]])
    low, high = responsive_range(t, u, np.array(["random"] * 50))
    assert np.all(low == -1.0) and np.all(high == 1.0)
    kinds = np.array(["neutral"] * 5 + ["random"] * 45)
    u[:5] = 0.0
    low, high = responsive_range(t, u, kinds)
    assert np.all(low == -1.0) and np.all(high == 1.0)


def test_a_faint_servo_is_weak_not_slack() -> None:
    """Both sides within the noise: the sweeps cannot tell, the range stays whole."""
    levels = [-1.0, -0.5, 0.5, 1.0]
    u = np.zeros((10, 2))
    kinds = ["neutral"] * 6 + ["sweep"] * 4
    u[6:, 0] = levels
    rng = np.random.default_rng(1)
    t = rng.normal(0.0, 0.001, (10, 4))
    low, high = responsive_range(t, u, np.array(kinds))
    assert list(low) == [-1.0, -1.0] and list(high) == [1.0, 1.0]


def test_clip_commands() -> None:
    u = np.array([[-1.0, 0.7], [0.5, -0.2]])
    out = clip_commands(u, np.array([-0.5, 0.0]), np.array([0.0, 0.6]))
    assert out.tolist() == [[-0.5, 0.6], [0.0, 0.0]]


@pytest.fixture(scope="module")
def fitted():  # type: ignore[no-untyped-def]
    babble = synthetic_babble(500, head=_head())
    return fit_learned_profile(babble, hardware(), FitOptions(candidates=("poly_ridge",)))


def test_the_fit_stores_the_ranges_and_reports_the_effective_error(fitted) -> None:  # type: ignore[no-untyped-def]
    learned = fitted.learned
    names = [s.name for s in hardware().servos]
    assert learned.dead == [names[i] for i in DEAD]
    low, high = command_range(learned)
    by_name = dict(zip(learned.outputs, zip(low, high, strict=True), strict=True))
    assert by_name[names[7]] == (-1.0, 0.0) and by_name[names[14]] == (0.0, 1.0)
    assert by_name[names[8]] == (-0.5, 0.5)
    report = learned.report
    assert set(report.effective_error) == set(report.servo_error) == set(learned.outputs)
    assert set(report.effective_candidates) == set(report.candidates)
    assert set(report.candidates) == {"poly_ridge", "regional poly_ridge"}
    for servo in (7, 14):  # the slack half is no longer an error
        name = names[servo]
        assert report.effective_error[name] < 0.6 * report.servo_error[name]
    untouched = names[0]
    assert report.effective_error[untouched] == report.servo_error[untouched]
    text = format_report(fitted)
    assert "effective" in text and "responsive -1.00 .. +0.00" in text
    assert ", effective " in describe_learned(learned)


def test_t_never_commands_travel_that_moves_nothing(fitted) -> None:  # type: ignore[no-untyped-def]
    targets = LearnedTargets(fitted, {})
    assert targets.planner is not None
    low, high = command_range(fitted.learned)
    rng = np.random.default_rng(5)
    scale = np.abs(targets.low) + np.abs(targets.high)
    for _ in range(50):
        t = rng.uniform(-2.0, 2.0, len(targets.inputs)) * scale  # far beyond the reach too
        u = targets.commands(t)
        assert np.all(u >= low - 1e-12) and np.all(u <= high + 1e-12)
