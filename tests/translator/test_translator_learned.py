"""T with a learned profile: retargeting, the inverse model, dead servos, and the same
smoothing, motion limits and safety rules as written profiles (services/translator/learned.py)."""

from __future__ import annotations

from typing import Any

import msgspec
import numpy as np
import pytest
from translator_fixtures import FPS, TOL

from facesynth.runtime.profiles import (
    ExclusiveRule,
    Learned,
    Profile,
    Safety,
    Smoothing,
    encode_learned_profile,
    load_profile,
    parse_learned_profile,
)
from facesynth.runtime.profiles.learned import PolyRidge, Report, pack
from facesynth.schemas.messages import Features
from facesynth.services.translator.core import TranslationError, Translator

INPUTS = ["brow_raise_inner_right", "jaw_open", "lip_corner_pull_right"]
ZERO = np.zeros(68)


def learned_profile(servos: int = 4, dead: int = 1, **top: Any) -> Profile:
    """head16_hardware's first ``servos`` servos, the last ``dead`` dead; servo i follows input
    i as ``u = t / 0.1`` (robot reach -0.05 .. 0.1); no smoothing, no speed limits unless set."""
    hardware = load_profile("head16_hardware")
    specs = [msgspec.structs.replace(s, max_speed=0.0) for s in hardware.servos[:servos]]
    names = [s.name for s in specs]
    outputs, dead_names = names[: servos - dead], names[servos - dead :]
    coef = np.zeros((len(outputs), len(INPUTS)))
    for i in range(len(outputs)):
        coef[i, i % len(INPUTS)] = 1.0
    learned = Learned(
        inputs=list(INPUTS),
        reach_low=pack(np.full(3, -0.05)),
        reach_high=pack(np.full(3, 0.1)),
        input_mean=pack(np.zeros(3)),
        input_scale=pack(np.full(3, 0.1)),
        outputs=outputs,
        dead=dead_names,
        inverse=PolyRidge(
            degree=1,
            powers=pack(np.eye(3)),
            coef=pack(coef),
            intercept=pack(np.zeros(len(outputs))),
        ),
        report=Report(model="poly_ridge", servo_error={}, candidates={}, samples=0, held_out=0),
    )
    fields: dict[str, Any] = {"smoothing": None, **top}
    return msgspec.structs.replace(hardware, servos=specs, learned=learned, **fields)


def frame(
    index: int, raw: dict[str, float], named: dict[str, float] | None = None, **kw: Any
) -> Features:
    return Features(
        seq=index,
        t_capture_ns=7,
        t_media_ns=round(index * 1e9 / FPS),
        face=kw.get("face", True),
        neutral_ready=True,
        raw=raw,
        named=named if named is not None else {k: 1.0 for k in raw},
    )


def brow(
    raw: dict[str, float], named: dict[str, float] | None = None, profile: Profile | None = None
) -> float:
    translator = Translator(profile or learned_profile())
    return translator.positions(ZERO, named=named or {}, raw=raw)["right_eyebrow"]


@pytest.mark.parametrize(
    ("r", "n", "expected"),
    [
        (0.05, 1.0, 1750.0),  # within the robot's reach: copied as it is
        (0.05, 0.25, 1625.0),  # a quarter of the performer's range: a quarter of the robot's
        (0.3, 1.0, 2000.0),  # beyond the robot's reach: clipped
        (-0.2, -1.0, 1250.0),  # the performer's extreme below: the robot's (-0.05)
        (-0.01, -1.0, 1450.0),
        (0.3, None, 2000.0),  # no scale: taken as it is, clipped
        (0.0, 1.0, 1500.0),
    ],
)
def test_retargeting_scales_only_where_the_robot_reaches_less(
    r: float, n: float | None, expected: float
) -> None:
    named = {} if n is None else {"brow_raise_inner_right": n}
    assert brow({"brow_raise_inner_right": r}, named) == pytest.approx(expected)


def test_missing_inputs_are_neutral_dead_servos_stay_and_reversed_is_ignored() -> None:
    profile = learned_profile()
    profile.servos[0].reversed = True  # the model learned the wiring
    profile.servos[3].reversed = True
    translator = Translator(profile)
    raw = {"brow_raise_inner_right": 0.05, "lip_corner_pull_right": float("nan")}
    positions = translator.positions(ZERO, named={}, raw=raw)
    assert positions == pytest.approx(
        {
            "right_eyebrow": 1750.0,
            "left_eyebrow": 1500.0,
            "middle_eyebrow": 1500.0,
            "right_eye_x": 1500.0,
        }
    )


def test_no_input_holds_and_no_face_returns_to_neutral() -> None:
    translator = Translator(learned_profile())
    assert translator.step(frame(0, {"brow_raise_inner_right": 0.1}))["right_eyebrow"] == 2000.0
    held = translator.step(frame(1, {}, named={"head_yaw": 0.0}))
    assert held["right_eyebrow"] == 2000.0
    lost = translator.step(frame(2, {"brow_raise_inner_right": 0.1}, face=False))
    assert 1500.0 <= lost["right_eyebrow"] < 2000.0  # ramping to neutral (neutral_ramp_s)


def test_a_model_that_overflows_holds_its_servos() -> None:
    """Found by fuzzing: a file's checks bound shapes and signs, not magnitudes, so a valid
    file may hold an input_scale of 5e-324 or coefficients of 1e300; the model's arithmetic
    then overflows to NaN, which went out as a position (NaN passes ``clamp``). Such an output
    holds its servo instead, its filter untouched, and the others still follow."""
    profile = learned_profile(smoothing=Smoothing(min_cutoff=0.5, beta=0.0, d_cutoff=1.0))
    assert profile.learned is not None
    coef = np.eye(3)
    coef[1, 1] = 1e300  # left_eyebrow: 1e300 * x, then 1e300 * x - 1e300 * x = NaN below
    coef[1, 0] = -1e300
    profile.learned.inverse = PolyRidge(
        degree=1, powers=pack(np.eye(3)), coef=pack(coef), intercept=pack(np.zeros(3))
    )
    loaded = parse_learned_profile(encode_learned_profile(profile))  # a valid file
    translator = Translator(loaded)
    first = translator.step(frame(0, {"brow_raise_inner_right": 0.0, "jaw_open": 0.0}))
    assert first["left_eyebrow"] == 1500.0  # 0 * 1e300: a finite command
    raw = {"brow_raise_inner_right": 1e-300, "jaw_open": 1e-300}  # 1e300 * 1e-299 = 10
    assert translator.step(frame(1, raw))["left_eyebrow"] == 1500.0  # -10 + 10 = 0, finite
    raw = {"brow_raise_inner_right": 0.1, "jaw_open": 0.1}  # 1e300 * 1: inf - inf = NaN
    for index in range(2, 5):
        out = translator.step(frame(index, raw))
        assert out["left_eyebrow"] == 1500.0  # held where it was
        assert all(np.isfinite(list(out.values())))
    assert out["right_eyebrow"] > 1600.0  # the others follow (smoothed)
    back = translator.step(frame(5, {"brow_raise_inner_right": 0.0, "jaw_open": 0.0}))
    assert back["left_eyebrow"] == 1500.0  # its filter never saw a NaN

    tiny = learned_profile()
    assert tiny.learned is not None
    tiny.learned.input_scale = pack(np.full(3, 5e-324))  # x = t / 5e-324 = inf
    tiny = parse_learned_profile(encode_learned_profile(tiny))
    out = Translator(tiny).step(frame(0, {"brow_raise_inner_right": 0.1}))
    assert out["right_eyebrow"] == 2000.0  # 1 * inf: clipped, the robot's reach
    assert out["left_eyebrow"] == 1500.0  # 0 * inf = NaN: held (at neutral, its start)


def test_smoothing_and_motion_limits_apply_to_learned_outputs() -> None:
    smooth = learned_profile(smoothing=Smoothing(min_cutoff=0.5, beta=0.0, d_cutoff=1.0))
    translator = Translator(smooth)
    assert translator.step(frame(0, {"brow_raise_inner_right": 0.0}))["right_eyebrow"] == 1500.0
    step = translator.step(frame(1, {"brow_raise_inner_right": 0.1}))["right_eyebrow"]
    assert 1500.0 < step < 1600.0  # filtered in range units, as written profiles
    translator.reset()
    assert translator.step(frame(2, {"brow_raise_inner_right": 0.1}))["right_eyebrow"] == 2000.0

    limited = learned_profile()
    limited.servos[0].max_speed = 3000.0  # µs/s: 100 µs a frame at 30 fps
    translator = Translator(limited)
    translator.step(frame(0, {"brow_raise_inner_right": 0.0}))
    moves = [
        translator.step(frame(i, {"brow_raise_inner_right": 0.1}))["right_eyebrow"]
        for i in range(1, 8)
    ]
    assert np.all(np.diff([1500.0, *moves]) <= 100.0 + TOL)
    assert moves[-1] == pytest.approx(2000.0)


def test_exclusive_rules_hold_for_learned_profiles() -> None:
    rule = ExclusiveRule(servos=["right_eyebrow", "left_eyebrow"], threshold=0.5)
    profile = learned_profile(safety=Safety(exclusive=[rule]))
    out = Translator(profile).step(frame(0, {"brow_raise_inner_right": 0.1, "jaw_open": 0.1}))
    beyond = [abs(out[n] - 1500.0) > 250.0 for n in ("right_eyebrow", "left_eyebrow")]
    assert sum(beyond) == 1


def test_mirror_swaps_the_performers_sides() -> None:
    profile = learned_profile(mirror=True)
    assert brow({"brow_raise_inner_left": 0.05}, profile=profile) == pytest.approx(1750.0)
    assert brow({"brow_raise_inner_right": 0.05}, profile=profile) == pytest.approx(1500.0)


def test_a_hardware_profile_is_refused() -> None:
    with pytest.raises(
        TranslationError,
        match=r"servos without a source \(right_eyebrow, left_eyebrow, middle_eyebrow, …\)",
    ):
        Translator(load_profile("head16_hardware"))


def test_resume_starts_learned_servos_where_they_are() -> None:
    limited = learned_profile()
    limited.servos[0].max_speed = 3000.0
    translator = Translator(limited)
    translator.resume({"right_eyebrow": 1800.0})
    moves = [translator.step(frame(i, {"brow_raise_inner_right": -0.05})) for i in range(2)]
    assert moves[0]["right_eyebrow"] == 1800.0  # from where the servo is, no jump
    assert moves[1]["right_eyebrow"] == pytest.approx(1700.0, abs=TOL)  # 100 µs a frame


@pytest.mark.parametrize("name", ["paper16", "head16_bs"])
def test_time_translator_runs_written_and_learned_profiles(name: str) -> None:
    from facesynth.services.translator.timing import time_translator

    assert 0 < time_translator(load_profile(name), frames=30, runs=1) < 50
    assert 0 < time_translator(learned_profile(), frames=30, runs=1) < 50


def test_outputs_stay_in_each_servos_responsive_range() -> None:
    """A servo slack above neutral (a cable that pulls one way) is never driven above it; one
    that stops moving the face at half travel is never driven beyond half (or below -0.3)."""
    profile = learned_profile()
    assert profile.learned is not None
    learned = msgspec.structs.replace(
        profile.learned,
        command_low=pack(np.array([-1.0, -0.3, -1.0])),
        command_high=pack(np.array([0.0, 0.5, 1.0])),
    )
    translator = Translator(msgspec.structs.replace(profile, learned=learned))
    up = {"brow_raise_inner_right": 0.1, "jaw_open": 0.1, "lip_corner_pull_right": 0.1}
    high = translator.positions(ZERO, named={}, raw=up)
    assert high["right_eyebrow"] == 1500.0  # slack above neutral: stays at neutral
    assert high["left_eyebrow"] == pytest.approx(1750.0)  # half of 500 µs, not 2000
    assert high["middle_eyebrow"] == pytest.approx(2000.0)  # the whole travel
    down = {name: -0.05 for name in up}
    low = translator.positions(ZERO, named={}, raw=down)
    assert low["right_eyebrow"] == pytest.approx(1250.0)  # u = -0.5, within its range
    assert low["left_eyebrow"] == pytest.approx(1350.0)  # u = -0.5 clipped to -0.3
