"""Fuzz the closed loop through the robot's camera: its state file (``NAME.loop``), and T with
the loop closed fed arbitrary performer frames and arbitrary faces of the robot.

* Mutated, damaged and random bytes of a valid state, and valid ones with extreme finite
  arrays: a :class:`LoopState` or a :class:`LoopStateError`, nothing else; every state accepted
  drives a translator through the robot's faces with every position finite and within limits.
* One planning profile (``tests/fuzz/test_fuzz_learned_profiles.py``'s), or its regional one
  corrected through each servo's region, with the loop closed, through streams of performer
  frames interleaved with the robot's faces (NaN, infinities, huge values, features missing,
  face lost, capture times from any clock, going back): every position finite and within the
  servo's limits.
"""

from __future__ import annotations

import msgspec
import numpy as np
import pytest
import test_fuzz_learned_profiles as profiles
from fuzzing import FUZZ, TIMEOUT, check_tally, outcome, tally
from hypothesis import given
from hypothesis import strategies as st
from mutations import damaged, mutated
from test_fuzz_learned_profiles import PLANNING, _check, extreme_arrays, frames

from facesynth.runtime.profiles import Profile
from facesynth.runtime.profiles.learned import Regional
from facesynth.schemas.messages import Features
from facesynth.services.translator.closed_loop import LoopOptions, LoopState
from facesynth.services.translator.core import Translator
from facesynth.services.translator.loop_state import (
    LoopStateError,
    decode_loop_state,
    encode_loop_state,
)

pytestmark = [pytest.mark.fuzz, TIMEOUT]

assert PLANNING.learned is not None
LEARNED = PLANNING.learned
N_IN, N_OUT = len(LEARNED.inputs), len(LEARNED.outputs)
STATE = LoopState(
    weights=np.random.default_rng(2).normal(0.0, 0.3, (N_IN, N_OUT + 1)),
    covariance=np.eye(N_OUT + 1) * 0.5,
    updates=40,
)
VALID = encode_loop_state(STATE, PLANNING.name, LEARNED)
TREE = msgspec.msgpack.decode(VALID)
#: A profile with a regional inverse: its loop corrects each servo through its region.
REGIONAL = next(p for p in profiles.VALID if p.learned and isinstance(p.learned.inverse, Regional))
#: Wide-open options: big steps, little damping, the integral and the lead at their largest,
#: the correction through each servo's region (the bounds must hold by themselves).
WILD = LoopOptions(
    max_step=2.0,
    max_correction=2.0,
    damping=1e-6,
    observation_gain=1.0,
    integral_gain=1.0,
    integral_leak=1.0,
    lead_s=1.0,
    regional=True,
)


def _encode(tree: object) -> bytes:
    return msgspec.msgpack.encode(tree)


state_files = st.one_of(
    mutated(TREE).map(_encode),
    mutated(TREE).map(_encode),
    extreme_arrays(TREE),
    extreme_arrays(TREE),
    damaged(VALID),
    st.binary(max_size=120),
)

FRAMES = frames()

#: Capture times of the robot's faces relative to the performer frame's instant: this frame,
#: a frame late, too old, from another clock far ahead or behind.
LAGS = [0, 0, 33_333_333, 10**9, -(10**12), 10**15]


def drive(
    profile: Profile,
    translator: Translator,
    performer: list[Features],
    robot: list[Features],
    lags: list[int],
) -> None:
    """Each performer frame translated (every position checked), then the robot's face seen."""
    for index, features in enumerate(performer):
        now = index * 33_333_333
        _check(profile, translator.step(features, now_ns=now))
        face = robot[index % len(robot)]
        captured = now - lags[index % len(lags)]
        translator.observe(msgspec.structs.replace(face, t_capture_ns=captured))


def test_loop_states_load_or_raise_loop_state_error() -> None:
    target = "loop_state.decode_loop_state"
    assert decode_loop_state(VALID, LEARNED).updates == 40

    @FUZZ
    @given(state_files, st.data())
    def case(data: bytes, more: st.DataObject) -> None:
        state = outcome(target, lambda: decode_loop_state(data, LEARNED), LoopStateError)
        if state is not None:
            # the frames drawn only for a state that loaded (most are refused)
            performer, robot = more.draw(FRAMES), more.draw(FRAMES)
            translator = Translator(PLANNING)
            translator.close_loop(WILD, state)
            drive(PLANNING, translator, performer, robot, [0])

    case()
    check_tally(target, "valid", "refused")


def test_closed_loop_translator_positions_stay_within_the_limits() -> None:
    target = "Translator.step (learned, closed loop)"
    record = tally(target)

    @FUZZ
    @given(
        frames(),
        frames(),
        st.lists(st.sampled_from(LAGS), min_size=1, max_size=4),
        st.booleans(),
        st.booleans(),
    )
    def case(
        performer: list[Features],
        robot: list[Features],
        lags: list[int],
        wild: bool,
        regional: bool,
    ) -> None:
        profile = REGIONAL if regional else PLANNING
        translator = Translator(profile)
        translator.close_loop(WILD if wild else LoopOptions(regional=regional))
        drive(profile, translator, performer * 3, robot, lags)
        loop = translator._learned.closed if translator._learned is not None else None
        assert loop is not None
        assert np.isfinite(loop.state.weights).all() and np.isfinite(loop.state.covariance).all()
        record.count("valid")

    case()
    check_tally(target, "valid")
