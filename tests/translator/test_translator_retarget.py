"""T with a learned profile that retargets into the robot's reach (a file's ``retarget``
options, services/translator/retarget.py): features the robot cannot show take no part in
the plan, each feature's weight reaches the plan, and every command stays within the
profile's limits and the servos' responsive ranges."""

from __future__ import annotations

import msgspec
import numpy as np
import pytest

from facesynth.runtime.profiles import Learned, Profile, load_profile
from facesynth.runtime.profiles.learned import PolyRidge, Report, Retarget, pack
from facesynth.schemas.messages import Features
from facesynth.services.translator.core import Translator
from facesynth.services.translator.self_model import SelfModelPlanner

#: jaw and brow the robot moved while babbling; the blink it did not (its commands explained
#: none of it: a head without lids reads a little through the skin).
INPUTS = ["jaw_open", "brow_raise_inner_right", "eyeBlinkLeft"]
ZERO = np.zeros(68)


def profile(retarget: Retarget | None, **fields: object) -> Profile:
    """Two live servos: ``right_eyebrow`` follows the jaw, ``left_eyebrow`` the brow (inverse
    ``u = x``, standardized by 0.1); the self-model says both also move the blink feature,
    so a plan that keeps the blink at its target trades the servos' travel for it."""
    hardware = load_profile("head16_hardware")
    specs = [msgspec.structs.replace(s, max_speed=0.0) for s in hardware.servos]
    names = [s.name for s in specs]
    forward = PolyRidge(
        degree=1,
        powers=pack(np.eye(2)),
        coef=pack(np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])),
        intercept=pack(np.zeros(3)),
    )
    learned = Learned(
        inputs=list(INPUTS),
        reach_low=pack(np.array([-0.05, -0.05, -0.02])),
        reach_high=pack(np.array([0.1, 0.1, 0.05])),
        input_mean=pack(np.zeros(3)),
        input_scale=pack(np.full(3, 0.1)),
        outputs=names[:2],
        dead=names[2:],
        inverse=PolyRidge(
            degree=1,
            powers=pack(np.eye(3)),
            coef=pack(np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])),
            intercept=pack(np.zeros(2)),
        ),
        forward=forward,
        plan_steps=8,
        plan_prior=0.0,
        noise=pack(np.array([0.001, 0.001, 0.1])),
        retarget=retarget,
        report=Report(model="poly_ridge", servo_error={}, candidates={}, samples=0, held_out=0),
    )
    learned = msgspec.structs.replace(learned, **fields)
    return msgspec.structs.replace(hardware, servos=specs, learned=learned, smoothing=None)


def frame(index: int, raw: dict[str, float]) -> Features:
    return Features(
        seq=index,
        t_capture_ns=0,
        t_media_ns=index * 33_333_333,
        face=True,
        neutral_ready=True,
        raw=raw,
        named={},
    )


def test_a_feature_the_robot_cannot_show_is_not_traded_against_one_it_can() -> None:
    def positions(retarget: Retarget | None, blink: float) -> list[float]:
        raw = {"jaw_open": 0.05, "brow_raise_inner_right": 0.0, "eyeBlinkLeft": blink}
        out = Translator(profile(retarget)).positions(ZERO, named={}, raw=raw)
        return [out["right_eyebrow"], out["left_eyebrow"]]

    # 0.9 of the jaw's 0.05 is 0.045, 0.45 of the robot's spread: u = 0.45, 1500 + 0.45 * 500;
    # whether she blinks or not
    for blink in (0.0, 0.8):
        assert positions(Retarget(), blink) == pytest.approx([1725.0, 1500.0], abs=0.5)
    # before retargeting (a version 1 file) the plan kept the blink near its target: with her
    # eyes open it gave up jaw travel and pushed the brow's servo the other way for it
    still = positions(None, 0.0)
    assert still[0] < 1700.0 and still[1] < 1490.0
    assert positions(None, 0.8) == pytest.approx([1750.0, 1500.0], abs=0.5)


def test_zero_weights_leave_a_feature_out_of_the_plan() -> None:
    forward = profile(None).learned.forward  # type: ignore[union-attr]
    assert isinstance(forward, PolyRidge)
    planner = SelfModelPlanner(forward, 8, 0.0)
    target = np.array([0.45, 0.2, 0.0])
    free = planner.plan(target, np.zeros(2), np.array([1.0, 1.0, 0.0]))
    assert free == pytest.approx([0.45, 0.2], abs=1e-3)  # the blink row has no say
    traded = planner.plan(target, np.zeros(2))
    assert np.abs(traded - free).max() > 0.05


def test_the_performers_movement_sets_the_weights_over_the_performance() -> None:
    translator = Translator(profile(Retarget(tau_s=1.0, min_weight=0.2)))
    learned = translator._learned
    assert learned is not None
    for index in range(60):  # two seconds: she moves her jaw, never her brow
        jaw = 0.3 * np.sin(index / 4.0)  # RMS 0.2: twice the robot spread
        translator.step(frame(index, {"jaw_open": jaw, "brow_raise_inner_right": 0.0}))
    assert learned.weights is not None
    assert learned.weights.tolist() == pytest.approx([1.0, 0.2, 0.0])


def test_commands_stay_within_the_limits_and_responsive_ranges_with_retargeting_on() -> None:
    ranged = profile(
        Retarget(),
        command_low=pack(np.array([-0.4, -1.0])),
        command_high=pack(np.array([1.0, 0.3])),
        plan_prior=0.5,
    )
    translator = Translator(ranged)
    rng = np.random.default_rng(27)
    extremes = [0.0, 1e6, -1e6, float("nan"), float("inf"), 1e-300]
    for index in range(300):
        raw = {
            name: float(rng.choice(extremes)) if rng.random() < 0.2 else rng.normal(0.0, 0.3)
            for name in INPUTS
        }
        positions = translator.step(frame(index, raw))
        for spec in ranged.servos:
            assert spec.min_us <= positions[spec.name] <= spec.max_us
        assert positions["right_eyebrow"] >= 1500.0 - 0.4 * 500 - 1e-6
        assert positions["left_eyebrow"] <= 1500.0 + 0.3 * 500 + 1e-6


def _jaw_ramp(translator: Translator, frames: range) -> list[float]:
    """``right_eyebrow`` (it follows the jaw) while her jaw opens at 0.03 a second."""
    return [
        translator.step(frame(i, {"jaw_open": 0.03 * i / 30, "brow_raise_inner_right": 0.0}))[
            "right_eyebrow"
        ]
        for i in frames
    ]


def test_open_loop_commands_are_led_by_their_rate_against_the_heads_lag() -> None:
    # the clip alone (extent 0), gain 1: u = jaw / 0.1, rising at 0.3 a second
    led = _jaw_ramp(Translator(profile(Retarget(gain=1.0, extent=0.0, lead_s=0.1))), range(45))
    unled = _jaw_ramp(Translator(profile(Retarget(gain=1.0, extent=0.0, lead_s=0.0))), range(45))
    assert unled[-1] == pytest.approx(1500.0 + 500 * 0.3 * 44 / 30, abs=0.01)
    # 0.1 s ahead: 0.03 of the servo's travel, 15 µs
    assert led[-1] - unled[-1] == pytest.approx(15.0, abs=0.05)
    assert led[0] == unled[0]  # the first frame has no rate yet


def test_a_reset_or_resume_forgets_the_rate() -> None:
    translator = Translator(profile(Retarget(gain=1.0, extent=0.0, lead_s=0.1)))
    unled = Translator(profile(Retarget(gain=1.0, extent=0.0, lead_s=0.0)))
    _jaw_ramp(translator, range(20))
    translator.reset()
    assert _jaw_ramp(translator, range(20, 21)) == _jaw_ramp(unled, range(20, 21))
    _jaw_ramp(translator, range(21, 40))
    _jaw_ramp(unled, range(21, 40))
    for each in (translator, unled):  # where the servo is: within the catch-up's reach
        each.resume({"right_eyebrow": 1500.0 + 500 * 0.3 * 40 / 30})
    assert _jaw_ramp(translator, range(40, 41)) == _jaw_ramp(unled, range(40, 41))


def test_a_file_without_lead_s_is_not_led() -> None:
    learned = Translator(profile(Retarget()))._learned
    assert learned is not None and learned.lead is None
