"""Fuzz learned profiles (``NAME.learned``, one msgpack file): the loader, and the translator's
learned path with the inputs it reads (``Features.raw``, scaled by ``Features.named``).

* Mutated, damaged and random bytes of valid files (a ridge, a k-nearest-neighbours, an MLP
  and a regional inverse model, and one that plans through a ``poly_ridge`` self-model),
  parsed from bytes or loaded from a file: a :class:`Profile` or a :class:`ProfileError`,
  nothing else. Besides the generic mutations, an array of a valid file may get extreme but
  finite values (1e300, 5e-324, ...), which its checks accept: every profile the loader
  accepts drives a translator and a control core with extreme features, every position
  finite and within the servo's limits.
* One valid planning profile (``plan_steps`` > 0, its forward model fitted as
  ``tests/translator/test_self_model.py`` does) through streams of arbitrary features (NaN,
  infinities, huge values, inputs missing, other keys, face lost, time going back).
"""

from __future__ import annotations

import math
from typing import Any

import msgspec
import numpy as np
import pytest
from fuzzing import FUZZ, TIMEOUT, check_tally, outcome, scratch_folder, tally
from hypothesis import given
from hypothesis import strategies as st
from mutations import damaged, mutated

from facesynth.app.learn.fit import FitOptions, fit_model
from facesynth.runtime.profiles import (
    Learned,
    Profile,
    ProfileError,
    encode_learned_profile,
    load_profile,
    parse_learned_profile,
)
from facesynth.runtime.profiles.learned import (
    KNN,
    MLP,
    Layer,
    Part,
    PolyRidge,
    Regional,
    Report,
    Retarget,
    pack,
)
from facesynth.schemas.messages import Features
from facesynth.services.control.core import Arrival, CommandError, ControlCore, StaleCommand
from facesynth.services.translator.core import Translator

pytestmark = [pytest.mark.fuzz, TIMEOUT]

INPUTS = ["brow_raise_inner_right", "jaw_open", "lip_corner_pull_left"]
HARDWARE = load_profile("head16_hardware")
SERVOS = 4  # the first four of head16_hardware; the last of them dead
SPECS = HARDWARE.servos[:SERVOS]
NAMES = [spec.name for spec in SPECS]
OUTPUTS, DEAD = NAMES[:-1], NAMES[-1:]
N_IN, N_OUT = len(INPUTS), len(OUTPUTS)


def _fitted_forward() -> PolyRidge:
    """A ``poly_ridge`` self-model (commands -> standardized inputs) fitted on a smooth,
    coupled, nonlinear face, as tests/translator/test_self_model.py fits one."""
    rng = np.random.default_rng(7)
    linear = rng.normal(0.0, 1.0, (N_IN, N_OUT))
    quadratic = rng.normal(0.0, 0.3, (N_IN, N_OUT))
    u = np.random.default_rng(0).uniform(-1.0, 1.0, (300, N_OUT))
    face = u @ linear.T + (u**2) @ quadratic.T
    _, model = fit_model("poly_ridge", u, face, FitOptions())
    assert isinstance(model, PolyRidge)
    return model


def _learned(inverse: Any, forward: Any = None, plan_steps: int = 0) -> Profile:
    """head16_hardware cut to four servos with a learned mapping from three inputs."""
    learned = Learned(
        inputs=list(INPUTS),
        reach_low=pack(np.full(N_IN, -0.05)),
        reach_high=pack(np.full(N_IN, 0.1)),
        input_mean=pack(np.zeros(N_IN)),
        input_scale=pack(np.full(N_IN, 0.1)),
        outputs=list(OUTPUTS),
        dead=list(DEAD),
        inverse=inverse,
        forward=forward,
        plan_steps=plan_steps,
        plan_prior=0.02,
        report=Report(
            model="poly_ridge",
            servo_error=dict.fromkeys(OUTPUTS, 0.02),
            candidates={"poly_ridge": 0.02},
            samples=100,
            held_out=20,
        ),
    )
    return msgspec.structs.replace(HARDWARE, servos=list(SPECS), learned=learned)


LINEAR = np.eye(N_OUT, N_IN)
RIDGE = PolyRidge(
    degree=1, powers=pack(np.eye(N_IN)), coef=pack(LINEAR), intercept=pack(np.zeros(N_OUT))
)
X = np.random.default_rng(0).normal(size=(12, N_IN))
RIDGE_TWO = PolyRidge(
    degree=2,
    powers=pack(np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])),
    coef=pack(np.array([[1.0, 0.2, -0.1], [0.0, 1.0, 0.3]])),
    intercept=pack(np.zeros(2)),
)
KNN_ONE = KNN(k=2, weights="uniform", train_x=pack(X[:, :1]), train_y=pack(np.tanh(X[:, :1])))
PLANNING = _learned(RIDGE, _fitted_forward(), plan_steps=4)
VALID = [
    _learned(
        RIDGE,
        MLP(
            activation="relu",
            layers=[
                Layer(weights=pack(np.ones((N_OUT, 4))), bias=pack(np.zeros(4))),
                Layer(weights=pack(np.ones((4, N_IN))), bias=pack(np.zeros(N_IN))),
            ],
        ),
    ),
    _learned(
        KNN(k=3, weights="distance", train_x=pack(X), train_y=pack(np.tanh(X @ LINEAR.T), "<f4"))
    ),
    _learned(
        MLP(
            activation="tanh",
            layers=[
                Layer(weights=pack(np.full((N_IN, 5), 0.3)), bias=pack(np.zeros(5))),
                Layer(weights=pack(np.full((5, N_OUT), -0.2)), bias=pack(np.zeros(N_OUT))),
            ],
        )
    ),
    PLANNING,
    # a regional inverse (file version 3): one model per region, each on its own inputs
    _learned(
        Regional(
            parts=[
                Part(inputs=[0, 2], outputs=[0, 2], model=RIDGE_TWO),
                Part(inputs=[1], outputs=[1], model=KNN_ONE),
            ]
        ),
        _fitted_forward(),
        plan_steps=2,
    ),
    # retargeting into the robot's reach (file version 2): its noise and options fuzzed too
    msgspec.structs.replace(
        PLANNING,
        learned=msgspec.structs.replace(
            PLANNING.learned,
            noise=pack(np.array([0.001, 0.2, 0.01])),
            retarget=Retarget(region_floor=0.5),
        ),
    ),
]
VALID_BYTES = [encode_learned_profile(profile) for profile in VALID]
VALID_TREES = [msgspec.msgpack.decode(data) for data in VALID_BYTES]

#: Finite values an array's checks accept that break careless arithmetic.
EXTREME = [0.0, 1.0, -1.0, 1e300, -1e300, 1.7976931348623157e308, 1e-300, 5e-324, 1e15, 3.0]


def _arrays(tree: Any, path: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Paths of every array (``{dtype, shape, data}``) in a decoded file."""
    if isinstance(tree, dict):
        if {"dtype", "shape", "data"} <= tree.keys():
            return [path]
        return [p for key, value in tree.items() for p in _arrays(value, (*path, key))]
    if isinstance(tree, list):
        return [p for index, value in enumerate(tree) for p in _arrays(value, (*path, index))]
    return []


_PATTERNS = st.lists(st.sampled_from(EXTREME), min_size=1, max_size=4)


@st.composite
def extreme_arrays(draw: st.DrawFn, tree: Any) -> bytes:
    """A valid file with one or two arrays' values replaced by extreme finite ones (the
    shape and dtype kept, so the file's checks pass unless a sign or range rule is broken)."""
    tree = msgspec.msgpack.decode(msgspec.msgpack.encode(tree))
    for _ in range(draw(st.integers(1, 2))):
        path = draw(st.sampled_from(_arrays(tree)))
        node = tree
        for step in path:
            node = node[step]
        size = math.prod(node["shape"])
        pattern = draw(_PATTERNS)
        values = np.resize(np.array(pattern), size)  # repeated: a few draws for any size
        if node["dtype"] == "<f4":
            values = np.clip(values, -3e38, 3e38)
        node["data"] = values.astype(node["dtype"]).tobytes()
    return msgspec.msgpack.encode(tree)


def _encode(tree: Any) -> bytes:
    return msgspec.msgpack.encode(tree)


learned_files = st.one_of(
    st.sampled_from(VALID_TREES).flatmap(lambda tree: mutated(tree)).map(_encode),
    st.sampled_from(VALID_TREES).flatmap(lambda tree: mutated(tree)).map(_encode),
    st.sampled_from(VALID_TREES).flatmap(extreme_arrays),
    st.sampled_from(VALID_TREES).flatmap(extreme_arrays),
    st.sampled_from(VALID_BYTES).flatmap(damaged),
    st.binary(max_size=120),
)


def _features(index: int, value: float, named: float | None) -> Features:
    """A tracked frame whose every raw input is ``value`` (scaled ``named``, or none)."""
    return Features(
        seq=index,
        t_capture_ns=0,
        t_media_ns=index * 33_333_333,
        face=True,
        neutral_ready=True,
        deltas=[value] * 68,
        named={} if named is None else dict.fromkeys(INPUTS, named),
        raw=dict.fromkeys(INPUTS, value),
    )


def _check(profile: Profile, positions: dict[str, float]) -> None:
    """Every servo there, finite and within its limits."""
    assert set(positions) == {spec.name for spec in profile.servos}
    for spec in profile.servos:
        value = positions[spec.name]
        assert math.isfinite(value) and spec.min_us <= value <= spec.max_us, (spec.name, value)


#: Raw input values (and their scaled value, None: not scaled) a driven profile sees.
EXTREME_FEATURES = [
    (0.0, 0.0),
    (0.08, 0.5),
    (-0.04, -0.5),
    (5.0, 5.0),
    (-5.0, None),
    (1e6, 1e6),
    (-1e300, -math.inf),
    (math.nan, math.nan),
]


def drive_learned(profile: Profile) -> None:
    """A translator and a control core of a learned profile through extreme features (as
    test_fuzz_loaders.drive does for written profiles, with the raw inputs a learned mapping
    reads): every position finite and within the servo's limits."""
    core = ControlCore(profile, motion_time="media")
    _check(profile, core.start(0).positions)
    translator = Translator(profile)
    for index, (value, named) in enumerate(EXTREME_FEATURES):
        commands = translator.translate(_features(index, value, named))
        _check(profile, commands.positions)
        try:
            move, _ = core.command(commands, Arrival(wall_ns=index, mono_ns=index))
        except (CommandError, StaleCommand):
            continue
        for name, position in move.positions.items():
            spec = profile.servo(name)
            assert spec.min_us <= position <= spec.max_us


def test_learned_profiles_load_or_raise_profile_error() -> None:
    target = "profiles.parse_learned_profile"
    for profile, data in zip(VALID, VALID_BYTES, strict=True):  # the seeds are valid files
        assert parse_learned_profile(data) == profile
    folder = scratch_folder("fuzz-learned-")
    file = folder / "robot.learned"

    @FUZZ
    @given(learned_files, st.sampled_from([1, 2, 3, 4, 5, 6, 7, 0]))
    def case(data: bytes, via: int) -> None:
        if via == 0:  # load_profile by path (the suffix says learned): 1 in 8, writes are slow
            file.write_bytes(data)
            profile = outcome(target, lambda: load_profile(str(file)), ProfileError)
        else:
            profile = outcome(target, lambda: parse_learned_profile(data), ProfileError)
        if profile is not None:
            assert profile.learned is not None
            drive_learned(profile)

    case()
    check_tally(target, "valid", "refused")


# --- T planning through the self-model ---------------------------------------------------------

#: Values an input may have in a frame (None: missing): in range, beyond it, non-finite, huge.
VALUES: list[float | None] = [
    *[None, None, None],
    *[math.nan, math.inf, -math.inf, 1e300, -1e300, 1e6, -1e6, 5e-324, -0.0],
    *[0.3, -0.3, 0.1, 0.07, 0.02, -0.01, -0.03, -0.05, 0.0],
]
#: Every (raw, named) pair of values an input may have.
PAIRS = [(r, n) for r in VALUES for n in VALUES]
#: Keys a frame may also carry, which the mapping must ignore.
OTHERS = ["head_yaw", "jaw_open_x", ""]
#: A frame's inputs, as one number: a pair per input and one for another key (its name too).
#: Drawing costs more than the translator here, so each frame takes two draws, this and
#: (media time step, face found, neutral ready).
CONTENTS = st.integers(0, len(PAIRS) ** (len(INPUTS) + 1) * len(OTHERS) - 1)
MOMENTS = st.sampled_from(
    [
        (step, face, ready)
        for step in [33_333_333, 33_333_333, 0, -50_000_000, 10**12, 1]
        for face, ready in [(True, True), (True, True), (False, True), (True, False)]
    ]
)


def _contents(code: int) -> tuple[dict[str, float], dict[str, float]]:
    """The raw and named inputs a :data:`CONTENTS` number stands for (missing: left out)."""
    code, other = divmod(code, len(OTHERS))
    raw, named = {}, {}
    for name in [*INPUTS, OTHERS[other]]:
        code, index = divmod(code, len(PAIRS))
        raw_value, named_value = PAIRS[index]
        if raw_value is not None:
            raw[name] = raw_value
        if named_value is not None:
            named[name] = named_value
    return raw, named


@st.composite
def frames(draw: st.DrawFn) -> list[Features]:
    """1..4 frames: each raw and named input arbitrary or missing, other keys, the face found
    or lost, the neutral ready or not, media time moving on, standing still or going back."""
    out = []
    t_ns = 0
    for index in range(draw(st.integers(1, 4))):
        step, face, ready = draw(MOMENTS)
        t_ns += step
        raw, named = _contents(draw(CONTENTS))
        out.append(
            Features(
                seq=index,
                t_capture_ns=0,
                t_media_ns=t_ns,
                face=face or index > 0,
                neutral_ready=ready,
                raw=raw,
                named=named,
            )
        )
    return out


def test_planning_translator_positions_stay_within_the_limits() -> None:
    target = "Translator.step (learned, self-model plan)"
    core_target = "ControlCore.command (learned translator)"
    assert PLANNING.learned is not None and PLANNING.learned.plan_steps > 0
    NEUTRAL = PLANNING.neutral_positions()
    record = tally(target)

    @FUZZ
    @given(frames())
    def case(stream: list[Features]) -> None:
        translator = Translator(PLANNING)
        core = ControlCore(PLANNING, motion_time="media")
        core.start(0)
        moved = False
        for index, features in enumerate(stream):
            commands = translator.translate(features)
            _check(PLANNING, commands.positions)
            moved |= any(abs(commands.positions[n] - v) > 1.0 for n, v in NEUTRAL.items())
            mono = (index + 1) * 33_000_000
            applied = outcome(
                core_target,
                lambda c=commands, m=mono: core.command(c, Arrival(wall_ns=m, mono_ns=m)),
                (CommandError, StaleCommand),
            )
            if applied is not None:
                for servo, value in applied[0].positions.items():
                    spec = PLANNING.servo(servo)
                    assert spec.min_us <= value <= spec.max_us
        record.count("moved" if moved else "neutral")

    case()
    check_tally(target, "moved", "neutral")
    check_tally(core_target, "valid", every_case=False)
