"""services.translator.core, the stateful translator: sources, smoothing, limits, neutral ramps."""

from __future__ import annotations

from typing import Any

import msgspec
import numpy as np
import pytest

from facesynth.runtime.calibration import Calibration
from facesynth.runtime.profiles import (
    Profile,
    ServoSpec,
    Smoothing,
    SmoothingOverride,
    load_profile,
)
from schemas.messages import Features
from services.translator.core import (
    TranslationError,
    Translator,
    deadband,
    mirror_named,
    scaled_position,
)

FPS = 30.0
DT = 1.0 / FPS
TOL = 1e-3  # µs: t_media_ns is whole nanoseconds, so frames are not all exactly 1/30 s


def _servo(name: str = "s", channel: int = 0, **kw: Any) -> ServoSpec:
    fields: dict[str, Any] = dict(
        name=name, channel=channel, min_us=1000.0, neutral_us=1500.0, max_us=2000.0
    )
    if not {"points", "feature", "mix"} & kw.keys():
        fields["feature"] = "jaw_open"
    fields.update(kw)
    return ServoSpec(**fields)


def _points_servo(name: str = "p", channel: int = 0, **kw: Any) -> ServoSpec:
    return _servo(name, channel, points=[56, 57, 58], face_min=-0.1, face_max=0.2, **kw)


def _profile(*servos: ServoSpec, **kw: Any) -> Profile:
    return Profile(name="t", servos=list(servos), **kw)


def _frame(
    index: int,
    named: dict[str, float] | None = None,
    deltas: list[float] | np.ndarray | None = None,
    *,
    face: bool = True,
    ready: bool = True,
    t_ns: int | None = None,
) -> Features:
    return Features(
        seq=index,
        t_capture_ns=7,
        t_media_ns=round(index * 1e9 / FPS) if t_ns is None else t_ns,
        face=face,
        neutral_ready=ready,
        deltas=[] if deltas is None else [float(v) for v in deltas],
        named={} if named is None else named,
    )


def _jaw(value: float) -> np.ndarray:
    deltas = np.zeros(68)
    deltas[[56, 57, 58]] = value
    return deltas


def _run(translator: Translator, frames: list[Features], servo: str = "s") -> list[float]:
    return [translator.step(frame)[servo] for frame in frames]


# --- mapping pieces ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("value", "width", "expected"),
    [
        (0.0, 0.1, 0.0),
        (0.05, 0.1, 0.0),
        (0.1, 0.1, 0.0),
        (0.1000001, 0.1, 0.0000001),
        (0.5, 0.1, 0.4),
        (-0.05, 0.1, 0.0),
        (-0.5, 0.1, -0.4),
        (0.3, 0.0, 0.3),
        (-0.3, 0.0, -0.3),
    ],
    ids=[
        "zero",
        "inside",
        "edge",
        "just-beyond",
        "beyond",
        "neg-inside",
        "neg-beyond",
        "off",
        "off-neg",
    ],
)
def test_deadband(value: float, width: float, expected: float) -> None:
    assert deadband(value, width) == pytest.approx(expected, abs=1e-12)


def test_deadband_is_continuous_through_the_translator() -> None:
    translator = Translator(_profile(_servo(deadband=0.1)))
    values = np.linspace(-1.2, 1.2, 2401)
    out = [translator.positions(np.zeros(68), {"jaw_open": v})["s"] for v in values]
    steps = np.abs(np.diff(out))
    assert steps.max() <= 500 * (values[1] - values[0]) + 1e-9  # no jump anywhere
    assert translator.positions(np.zeros(68), {"jaw_open": 0.1})["s"] == 1500.0
    assert translator.positions(np.zeros(68), {"jaw_open": 0.6})["s"] == pytest.approx(1750.0)
    assert translator.positions(np.zeros(68), {"jaw_open": -0.6})["s"] == pytest.approx(1250.0)


ASYM = _servo(min_us=900.0, neutral_us=1200.0, max_us=2100.0)


@pytest.mark.parametrize(
    ("spec", "value", "expected"),
    [
        (_servo(), 0.0, 1500.0),
        (_servo(), 1.0, 2000.0),
        (_servo(), -1.0, 1000.0),
        (_servo(), 0.5, 1750.0),
        (_servo(), 1.5, 2000.0),
        (_servo(), -1.5, 1000.0),
        (_servo(reversed=True), 0.5, 1250.0),
        (_servo(reversed=True), -1.0, 2000.0),
        (ASYM, 0.5, 1650.0),
        (ASYM, -0.5, 1050.0),
        (_servo(min_us=0.0, neutral_us=0.0, max_us=1000.0), -0.5, 0.0),
    ],
    ids=[
        "zero",
        "one",
        "minus-one",
        "half",
        "beyond-clamped",
        "below-clamped",
        "reversed-half",
        "reversed-minus-one",
        "asym-up",
        "asym-down",
        "one-sided-negative",
    ],
)
def test_scaled_position(spec: ServoSpec, value: float, expected: float) -> None:
    assert scaled_position(value, spec) == pytest.approx(expected)


SMILE = {"lip_corner_pull_right": 1.0, "lip_corner_depress_right": -1.0}


@pytest.mark.parametrize(
    ("mix", "named", "expected"),
    [
        (SMILE, {"lip_corner_pull_right": 0.0, "lip_corner_depress_right": 0.0}, 1500.0),
        (SMILE, {"lip_corner_pull_right": 0.6, "lip_corner_depress_right": 0.0}, 1800.0),
        (SMILE, {"lip_corner_pull_right": 0.0, "lip_corner_depress_right": 0.6}, 1200.0),
        (SMILE, {"lip_corner_pull_right": 0.6, "lip_corner_depress_right": 0.6}, 1500.0),
        (SMILE, {"lip_corner_pull_right": 0.8, "lip_corner_depress_right": 0.2}, 1800.0),
        (SMILE, {"lip_corner_pull_right": 1.5, "lip_corner_depress_right": 0.0}, 2000.0),
        (
            {"brow_raise_inner_right": 0.5, "brow_raise_outer_right": 0.5, "brow_lower_right": -1},
            {"brow_raise_inner_right": 1.0, "brow_raise_outer_right": 0.2, "brow_lower_right": 0.1},
            1750.0,
        ),
    ],
    ids=["neutral", "smile", "frown", "cancel", "net-smile", "clamped", "brow-three"],
)
def test_mix_is_a_weighted_sum(
    mix: dict[str, float], named: dict[str, float], expected: float
) -> None:
    translator = Translator(_profile(_servo(mix=mix)))
    assert translator.positions(np.zeros(68), named)["s"] == pytest.approx(expected)
    assert translator.step(_frame(0, named))["s"] == pytest.approx(expected)


@pytest.mark.parametrize(
    ("spec", "source", "expected"),
    [
        (_servo(gain=2.0), {"jaw_open": 0.25}, 1750.0),
        (_servo(gain=0.5), {"jaw_open": -1.0}, 1250.0),
        (_servo(gain=-1.0), {"jaw_open": 0.5}, 1250.0),
        (_servo(reversed=True, gain=2.0), {"jaw_open": 0.25}, 1250.0),
        (_servo(gain=2.0, deadband=0.1), {"jaw_open": 0.35}, 1750.0),  # (0.35 - 0.1) * 2
        (_points_servo(name="s", gain=2.0), _jaw(0.05), 1750.0),
        (_points_servo(name="s", reversed=True), _jaw(0.1), 1250.0),
        (_points_servo(name="s", deadband=0.02), _jaw(0.12), 1750.0),
        (_points_servo(name="s", deadband=0.02), _jaw(-0.01), 1500.0),
    ],
    ids=[
        "gain-2",
        "gain-half-negative",
        "gain-minus-1",
        "reversed-gain",
        "gain-after-deadband",
        "points-gain",
        "points-reversed",
        "points-deadband-iod",
        "points-inside-deadband",
    ],
)
def test_gain_reversed_deadband(
    spec: ServoSpec, source: dict[str, float] | np.ndarray, expected: float
) -> None:
    translator = Translator(_profile(spec))
    frame = _frame(0, source) if isinstance(source, dict) else _frame(0, deltas=source)
    assert translator.step(frame)["s"] == pytest.approx(expected)


@pytest.mark.parametrize(
    ("named", "mirrored"),
    [
        ({"jaw_open": 0.3}, {"jaw_open": 0.3}),
        ({"gaze_right_x": 0.5}, {"gaze_left_x": -0.5}),
        ({"gaze_left_y": 0.5}, {"gaze_right_y": 0.5}),
        ({"brow_raise_inner_right": 0.2}, {"brow_raise_inner_left": 0.2}),
        ({"head_yaw": 0.4, "head_pitch": 0.1}, {"head_yaw": -0.4, "head_pitch": 0.1}),
        (
            {"lip_corner_pull_left": 0.7, "lip_corner_pull_right": 0.1},
            {"lip_corner_pull_right": 0.7, "lip_corner_pull_left": 0.1},
        ),
    ],
    ids=["central", "gaze-x", "gaze-y", "brow", "head", "swap-both"],
)
def test_mirror_named(named: dict[str, float], mirrored: dict[str, float]) -> None:
    assert mirror_named(named) == mirrored
    assert mirror_named(mirror_named(named)) == named


def test_mirror_drives_the_right_eye_from_the_left() -> None:
    profile = _profile(_servo("eye", feature="gaze_right_x"), mirror=True)
    out = Translator(profile).step(_frame(0, {"gaze_left_x": 0.5, "gaze_right_x": -0.2}))
    assert out["eye"] == pytest.approx(1250.0)  # the performer looks left: the image looks right


# --- missing sources --------------------------------------------------------------------------


def test_missing_feature_holds_then_resumes() -> None:
    profile = _profile(_servo("gaze", feature="gaze_right_y"), _servo("jaw", 1))
    translator = Translator(profile)
    frames = [
        _frame(0, {"jaw_open": 0.2}),  # no gaze yet: neutral
        _frame(1, {"jaw_open": 0.2, "gaze_right_y": 0.5}),
        _frame(2, {"jaw_open": 0.4}),  # gaze missing: hold
        _frame(3, {"jaw_open": 0.4}),
        _frame(4, {"jaw_open": 0.4, "gaze_right_y": -0.5}),
    ]
    out = [translator.step(frame) for frame in frames]
    assert [o["gaze"] for o in out] == pytest.approx([1500.0, 1750.0, 1750.0, 1750.0, 1250.0])
    assert [o["jaw"] for o in out] == pytest.approx([1600.0, 1600.0, 1700.0, 1700.0, 1700.0])


def test_missing_mix_component_holds() -> None:
    translator = Translator(_profile(_servo(mix=SMILE)))
    assert translator.step(
        _frame(0, {"lip_corner_pull_right": 0.5, "lip_corner_depress_right": 0})
    )["s"] == pytest.approx(1750.0)
    assert translator.step(_frame(1, {"lip_corner_pull_right": 0.0}))["s"] == pytest.approx(1750.0)


def test_points_servo_without_deltas_holds() -> None:
    translator = Translator(_profile(_points_servo(name="s"), _servo("jaw", 1)))
    assert translator.step(_frame(0, deltas=_jaw(0.1)))["s"] == pytest.approx(1750.0)
    out = translator.step(_frame(1, {"jaw_open": 0.5}))  # named only: the group holds
    assert out == pytest.approx({"s": 1750.0, "jaw": 1750.0})


def test_points_fallback_until_the_feature_is_seen() -> None:
    eye = _servo("eye", feature="gaze_right_y", points=[56, 57, 58], face_min=-0.1, face_max=0.2)
    translator = Translator(_profile(eye))
    # A stream without an iris (OpenFace replay): the Table 1 group drives the eye.
    assert translator.step(_frame(0, deltas=_jaw(0.1)))["eye"] == pytest.approx(1750.0)
    assert translator.step(_frame(1, deltas=_jaw(-0.05)))["eye"] == pytest.approx(1250.0)
    # Gaze arrives: it drives the eye from now on ...
    assert translator.step(_frame(2, {"gaze_right_y": 0.8}, _jaw(0.1)))["eye"] == pytest.approx(
        1900.0
    )
    # ... and a frame without it holds, it does not fall back to the lid points.
    assert translator.step(_frame(3, deltas=_jaw(-0.1)))["eye"] == pytest.approx(1900.0)
    translator.reset()
    assert translator.step(_frame(4, deltas=_jaw(0.2)))["eye"] == pytest.approx(2000.0)


def test_fallback_deadband_is_in_scaled_units() -> None:
    eye = _servo(
        "eye",
        feature="gaze_right_y",
        points=[56, 57, 58],
        face_min=-0.1,
        face_max=0.1,
        deadband=0.1,
    )
    translator = Translator(_profile(eye))
    # Half range 0.1 IOD: the dead-band 0.1 (scaled) is 0.01 IOD on the points.
    assert translator.step(_frame(0, deltas=_jaw(0.06)))["eye"] == pytest.approx(1750.0)


# --- neutral on face loss, ramps and rate limits ----------------------------------------------


def test_face_loss_ramps_linearly_to_neutral() -> None:
    translator = Translator(_profile(_servo(), neutral_ramp_s=0.5))
    translator.step(_frame(0, {"jaw_open": 1.0}))
    out = _run(translator, [_frame(i, face=False) for i in range(1, 25)])
    expected_step = 500.0 / 0.5 * DT  # 500 µs to go in 0.5 s
    steps = np.diff([2000.0, *out])
    assert np.all(steps <= 0)
    assert np.all(np.abs(steps) <= expected_step + TOL)  # never a jump
    assert -steps[:14] == pytest.approx([expected_step] * 14)
    assert out[14] == pytest.approx(1500.0)  # there after 15 frames = 0.5 s
    assert out[-1] == 1500.0


@pytest.mark.parametrize(
    "lost",
    [
        {"face": False},
        {"ready": False},
        {"face": True, "named": {}},
    ],
    ids=["no-face", "neutral-not-ready", "no-features"],
)
def test_every_kind_of_no_tracking_ramps(lost: dict[str, Any]) -> None:
    translator = Translator(_profile(_servo(), neutral_ramp_s=1.0))
    translator.step(_frame(0, {"jaw_open": -1.0}))
    named = lost.pop("named", None)
    out = translator.step(_frame(1, named, **lost))["s"]
    assert out == pytest.approx(1000.0 + 500.0 * DT)


def test_face_loss_uses_max_speed_when_set() -> None:
    translator = Translator(_profile(_servo(max_speed=3000.0), neutral_ramp_s=5.0))
    translator.step(_frame(0, {"jaw_open": 1.0}))
    out = _run(translator, [_frame(i, face=False) for i in range(1, 8)])
    assert out[:4] == pytest.approx([1900.0, 1800.0, 1700.0, 1600.0])
    assert out[4:] == pytest.approx([1500.0] * 3)


def test_face_return_catches_up_then_tracks() -> None:
    translator = Translator(_profile(_servo(), neutral_ramp_s=0.5))
    translator.step(_frame(0, face=False))
    catch_up = 1000.0 / 0.5 * DT  # the full travel per ramp time
    out = _run(translator, [_frame(i, {"jaw_open": 1.0}) for i in range(1, 10)])
    steps = np.diff([1500.0, *out])
    assert np.all(steps <= catch_up + TOL)
    assert out[:7] == pytest.approx([1500.0 + catch_up * (i + 1) for i in range(7)])
    assert out[7:] == pytest.approx([2000.0, 2000.0])
    # Caught up: tracking is unlimited again (this servo has no max_speed).
    assert translator.step(_frame(10, {"jaw_open": -1.0}))["s"] == pytest.approx(1000.0)


def test_neutral_ramp_zero_jumps_as_before() -> None:
    translator = Translator(_profile(_servo(), neutral_ramp_s=0.0))
    translator.step(_frame(0, {"jaw_open": 1.0}))
    assert translator.step(_frame(1, face=False))["s"] == 1500.0
    assert translator.step(_frame(2, {"jaw_open": 1.0}))["s"] == 2000.0


@pytest.mark.parametrize(
    ("speed", "accel"),
    [(3000.0, 0.0), (2500.0, 30000.0), (0.0, 20000.0), (6000.0, 0.0)],
    ids=["speed", "speed-accel", "accel-only", "eyes"],
)
def test_tracking_is_rate_limited(speed: float, accel: float) -> None:
    translator = Translator(_profile(_servo(max_speed=speed, max_accel=accel)))
    values = np.random.default_rng(3).uniform(-1.2, 1.2, 60).repeat(5)
    out = _run(translator, [_frame(i, {"jaw_open": float(v)}) for i, v in enumerate(values)])
    steps = np.diff(out)
    if speed:
        assert np.abs(steps).max() <= speed * DT + TOL
    if accel:
        assert np.abs(np.diff(steps)).max() <= accel * DT * DT + TOL
    assert all(1000.0 <= v <= 2000.0 for v in out)
    held = _run(translator, [_frame(300 + i, {"jaw_open": 0.5}) for i in range(60)])
    assert held[-1] == pytest.approx(1750.0)  # reaches the target


def test_repeated_frame_time_holds_the_output() -> None:
    translator = Translator(
        _profile(_servo(max_speed=3000.0), smoothing=Smoothing(min_cutoff=1.0, beta=0.5))
    )
    first = translator.step(_frame(0, {"jaw_open": 0.0}))["s"]
    second = translator.step(_frame(1, {"jaw_open": 1.0}))["s"]
    again = translator.step(_frame(1, {"jaw_open": -1.0}))["s"]  # same t_media_ns
    assert first == 1500.0 and 1500.0 < second == again


def test_looped_replay_time_going_back_does_not_jump() -> None:
    translator = Translator(_profile(_servo(max_speed=3000.0)))
    _run(translator, [_frame(i, {"jaw_open": 1.0}) for i in range(20)])
    out = _run(translator, [_frame(i, {"jaw_open": -1.0}) for i in range(5)])  # t restarts at 0
    assert out[0] == 2000.0  # held on the backward step
    assert np.abs(np.diff([2000.0, *out])).max() <= 3000.0 * DT + TOL


# --- smoothing --------------------------------------------------------------------------------


SMOOTH = Smoothing(min_cutoff=0.5, beta=1.0, d_cutoff=1.0)


def _noisy(n: int = 300, sigma: float = 0.1) -> np.ndarray:
    return np.random.default_rng(11).normal(0.2, sigma, n)


def test_smoothing_reduces_jitter() -> None:
    values = _noisy()
    frames = [_frame(i, {"jaw_open": float(v)}) for i, v in enumerate(values)]
    raw = _run(Translator(_profile(_servo())), frames)
    smooth = _run(Translator(_profile(_servo(), smoothing=SMOOTH)), frames)
    assert np.std(smooth[30:]) < 0.5 * np.std(raw[30:])
    assert np.mean(smooth[30:]) == pytest.approx(np.mean(raw[30:]), abs=10.0)


@pytest.mark.parametrize(
    "smoothing",
    [None, Smoothing(enabled=False, min_cutoff=0.1)],
    ids=["absent", "disabled"],
)
def test_no_smoothing_is_the_plain_mapping(smoothing: Smoothing | None) -> None:
    values = _noisy(50)
    translator = Translator(_profile(_servo(), smoothing=smoothing))
    out = _run(translator, [_frame(i, {"jaw_open": float(v)}) for i, v in enumerate(values)])
    expected = [translator.positions(np.zeros(68), {"jaw_open": float(v)})["s"] for v in values]
    assert out == pytest.approx(expected)


def test_points_are_filtered_in_range_units() -> None:
    # The same movement as a point group (half range 0.1 IOD) and as a scaled feature.
    values = _noisy(100)
    profile = _profile(
        _servo("named", 0),
        _servo("group", 1, points=[56, 57, 58], face_min=-0.1, face_max=0.1),
        smoothing=SMOOTH,
    )
    translator = Translator(profile)
    frames = [_frame(i, {"jaw_open": float(v)}, _jaw(0.1 * v)) for i, v in enumerate(values)]
    out = [translator.step(frame) for frame in frames]
    assert [o["group"] for o in out] == pytest.approx([o["named"] for o in out])


def test_per_servo_override_and_shared_filters() -> None:
    profile = _profile(
        _servo("a", 0),
        _servo("b", 1),
        _servo("c", 2, smoothing=SmoothingOverride(min_cutoff=5.0)),
        _servo("d", 3, smoothing=SmoothingOverride(enabled=False)),
        smoothing=SMOOTH,
    )
    values = _noisy(100)
    translator = Translator(profile)
    out = [translator.step(_frame(i, {"jaw_open": float(v)})) for i, v in enumerate(values)]
    a, b, c, d = ([o[n] for o in out] for n in "abcd")
    assert a == b  # one signal, one filter, one output
    assert np.std(a[30:]) < np.std(c[30:]) < np.std(d[30:])
    assert d == pytest.approx([1500.0 + 500.0 * v for v in values])
    assert profile.smoothing_for(profile.servos[2]) == Smoothing(
        min_cutoff=5.0, beta=1.0, d_cutoff=1.0
    )
    assert profile.smoothing_for(profile.servos[3]) is None


def test_override_without_a_profile_table() -> None:
    profile = _profile(_servo(smoothing=SmoothingOverride(beta=2.0)))
    assert profile.smoothing_for(profile.servos[0]) == Smoothing(beta=2.0)


# --- state, determinism, compatibility --------------------------------------------------------


def _random_session(seed: int) -> list[Features]:
    rng = np.random.default_rng(seed)
    frames = []
    for i in range(200):
        face = not 80 <= i < 110
        named = {"jaw_open": float(rng.normal(0, 0.5)), "gaze_right_y": float(rng.normal(0, 0.3))}
        if i % 17 == 0:
            named.pop("gaze_right_y")
        frames.append(_frame(i, named if face else None, rng.normal(0, 0.05, 68), face=face))
    return frames


@pytest.mark.parametrize("name", ["virtual", "paper16"])
def test_same_inputs_same_outputs_after_reset(name: str) -> None:
    translator = Translator(load_profile(name))
    frames = _random_session(5)
    first = [translator.step(frame) for frame in frames]
    translator.reset()
    second = [translator.step(frame) for frame in frames]
    fresh = Translator(load_profile(name))
    third = [fresh.step(frame) for frame in frames]
    assert first == second == third
    assert len({tuple(o.values()) for o in first}) > 100  # it did move


def test_without_reset_the_state_carries_over() -> None:
    translator = Translator(load_profile("virtual"))
    frames = _random_session(5)
    first = [translator.step(frame) for frame in frames]
    assert [translator.step(frame) for frame in frames] != first


def test_old_style_profile_is_the_paper_mapping_frame_by_frame() -> None:
    # Only points + face ranges, no smoothing or limits: the output is the stateless mapping,
    # also on repeated and backward timestamps.
    old = _profile(
        _points_servo("jaw", 0),
        _servo("brow", 1, points=[17, 18, 19, 20], face_min=-0.06, face_max=0.08, reversed=True),
    )
    translator = Translator(old)
    rng = np.random.default_rng(2)
    times = [0, 33, 66, 66, 100, 20, 133, 133]
    for index, t_ms in enumerate(times):
        deltas = rng.normal(0, 0.08, 68)
        expected = translator.positions(deltas)
        assert translator.step(_frame(index, deltas=deltas, t_ns=t_ms * 10**6)) == expected


def test_wrong_delta_count_leaves_the_state_alone() -> None:
    translator = Translator(_profile(_points_servo("s", max_speed=3000.0)))
    translator.step(_frame(0, deltas=_jaw(0.2)))
    with pytest.raises(TranslationError, match="need 68 deltas, got 3"):
        translator.step(_frame(1, deltas=[0.0, 0.0, 0.0]))
    assert translator.step(_frame(1, deltas=_jaw(0.2)))["s"] == 2000.0


def test_translate_carries_the_header() -> None:
    translator = Translator(_profile(_servo()))
    commands = translator.translate(_frame(3, {"jaw_open": 0.5}))
    assert (commands.seq, commands.t_capture_ns, commands.t_media_ns, commands.face) == (
        3,
        7,
        100_000_000,
        True,
    )
    assert commands.profile == "t" and commands.positions == {"s": 1750.0}


def test_calibration_leaves_named_servos_alone() -> None:
    calibration = Calibration(
        name="c", neutral=[1.0] * 68, delta_min=[-0.5] * 68, delta_max=[0.5] * 68
    )
    translator = Translator(_profile(_servo("a", 0), _points_servo("b", 1)), calibration)
    assert translator._ranges == [(-1.0, 1.0), (-0.5, 0.5)]
    out = translator.step(_frame(0, {"jaw_open": 0.5}, _jaw(0.25)))
    assert out == pytest.approx({"a": 1750.0, "b": 1750.0})


# --- shipped profiles -------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("named", "servo", "expected"),
    [
        ({"gaze_right_y": 1.05}, "right_eye_y", 2000.0),  # up (0.05 dead-band)
        ({"gaze_right_y": -0.55}, "right_eye_y", 1250.0),  # down
        ({"gaze_left_x": 0.55}, "left_eye_x", 1750.0),  # toward the performer's left
        ({"gaze_right_x": -1.05}, "right_eye_x", 1000.0),
    ],
    ids=["right-up", "right-down", "left-x", "right-x-min"],
)
def test_paper16_eyes_follow_the_iris(named: dict[str, float], servo: str, expected: float) -> None:
    out = Translator(load_profile("paper16")).step(_frame(0, named, np.zeros(68)))
    assert out[servo] == pytest.approx(expected)
    assert {n: v for n, v in out.items() if n != servo} == {n: 1500.0 for n in out if n != servo}


@pytest.mark.parametrize(
    ("named", "expected"),
    [
        ({"jaw_open": 1.0}, {"jaw": 1000.0}),
        ({"jaw_open": -0.5}, {"jaw": 0.0}),
        ({"lips_part": 0.5}, {"lower_lip": 500.0}),
        ({"lip_corner_pull_left": 1.0, "lip_corner_depress_left": 0.0}, {"lip_corner_left": 1000}),
        ({"lip_corner_pull_right": 0.0, "lip_corner_depress_right": 1.0}, {"lip_corner_right": 0}),
        (
            {"brow_raise_inner_right": 1.0, "brow_raise_outer_right": 1.0, "brow_lower_right": 0},
            {"brow_right": 1000.0},
        ),
        (
            {"brow_raise_inner_left": 0.0, "brow_raise_outer_left": 0.0, "brow_lower_left": 0.5},
            {"brow_left": 250.0},
        ),
        ({"eye_open_right": -1.0}, {"lid_right": 0.0}),
        ({"cheek_raise_left": 0.3}, {"cheek_left": 300.0}),
        ({"gaze_left_y": 0.55}, {"gaze_left_y": 750.0}),
    ],
    ids=[
        "jaw-open",
        "jaw-clenched",
        "lips-part",
        "smile-left",
        "frown-right",
        "brow-up",
        "brow-frown",
        "lid-closed",
        "cheek",
        "gaze-up",
    ],
)
def test_virtual_controls(named: dict[str, float], expected: dict[str, float]) -> None:
    profile = load_profile("virtual")
    out = Translator(profile).step(_frame(0, named))
    assert out == pytest.approx({**profile.neutral_positions(), **expected})


def test_virtual_with_limits_swapped_in_still_works() -> None:
    profile = load_profile("virtual")
    servos = [msgspec.structs.replace(s, max_speed=1000.0) for s in profile.servos]
    translator = Translator(msgspec.structs.replace(profile, servos=servos))
    translator.step(_frame(0, {"jaw_open": 0.0}))
    assert translator.step(_frame(1, {"jaw_open": 1.0}))["jaw"] == pytest.approx(1000.0 * DT)


# --- the smoothing benchmark ------------------------------------------------------------------


def test_bench_smoothing_reports_less_jitter_and_some_lag() -> None:
    from facesynth.app.bench.smoothing import bench_smoothing, format_smoothing

    result = bench_smoothing(seconds=4.0)
    rows = {(r["servo"], r["chain"]): r for r in result["rows"]}
    for servo in ("right_eyebrow", "right_eye_x"):
        raw, euro, shipped = (rows[(servo, c)] for c in ("unfiltered", "one euro", "shipped"))
        assert raw["step_50_ms"] == raw["step_90_ms"] == 0.0
        assert shipped["jitter_std_us"] < euro["jitter_std_us"] < 0.6 * raw["jitter_std_us"]
        assert 0.0 < euro["step_90_ms"] <= 200.0
    assert result == bench_smoothing(seconds=4.0)  # seeded: the same figures every run
    text = format_smoothing(result)
    assert "jitter std µs" in text and "right_eye_x      shipped" in text
    with pytest.raises(ValueError, match="has no servos \\['tail'\\]"):
        bench_smoothing(servos=["tail"])
