"""Fuzz the loaders of configuration and learned data: profiles (TOML), calibrations (JSON),
graphs (TOML) and F's learned state (JSON). What a loader accepts is then used as the chain
would: a profile drives a translator and a control core (positions within its limits), a
calibration a translator and F, a learned state F."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any

import msgspec
import numpy as np
import pytest
from fuzzing import FUZZ, TIMEOUT, check_tally, outcome, scratch_folder
from hypothesis import given
from hypothesis import strategies as st
from mutations import damaged, damaged_text, mutated, to_json, to_toml

from facesynth.app.graph import GraphError, load_graph
from facesynth.runtime import codec
from facesynth.runtime.calibration import Calibration, CalibrationError, parse_calibration
from facesynth.runtime.feature_names import NAMES
from facesynth.runtime.profiles import (
    Profile,
    ProfileError,
    available_profiles,
    parse_profile,
    resolve_profile,
)
from facesynth.schemas.messages import Features, Points
from facesynth.services.control.core import Arrival, CommandError, ControlCore, StaleCommand
from facesynth.services.features.core import FeatureProcessor
from facesynth.services.features.state import LearnedState, StateError, parse_state, restore
from facesynth.services.translator.core import TranslationError, Translator
from facesynth.services.translator.learned import unsourced

pytestmark = [pytest.mark.fuzz, TIMEOUT]

ROOT = Path(__file__).resolve().parents[2]
POINTS = codec.decode((ROOT / "tests/fixtures/messages/points_face.msgpack").read_bytes(), Points)


def _features(index: int, value: float, named: list[str]) -> Features:
    return Features(
        seq=index,
        t_capture_ns=0,
        t_media_ns=index * 33_333_333,
        face=True,
        neutral_ready=True,
        deltas=[value] * 68,
        named=dict.fromkeys(named, value),
    )


def drive(profile: Profile, calibration: Calibration | None = None) -> None:
    """A translator and a control core of ``profile`` through extreme features: every
    position finite and within the profile's limits. A hardware profile (servos without a
    source) drives C alone: T refuses it with its own error, which is checked here too."""
    specs = {spec.name: spec for spec in profile.servos}
    core = ControlCore(profile, motion_time="media")
    for name, value in core.start(0).positions.items():
        assert specs[name].min_us <= value <= specs[name].max_us
    if unsourced(profile) is not None:
        with pytest.raises(TranslationError):
            Translator(profile, calibration)
        return
    translator = Translator(profile, calibration)
    named = sorted(NAMES)
    for index, value in enumerate([0.0, 5.0, -5.0, 1e6, -1e6, 0.5]):
        commands = translator.translate(_features(index, value, named))
        for name, position in commands.positions.items():
            spec = specs[name]
            assert math.isfinite(position) and spec.min_us <= position <= spec.max_us
        try:
            move, _ = core.command(commands, Arrival(wall_ns=index, mono_ns=index))
        except (CommandError, StaleCommand):
            continue
        for name, position in move.positions.items():
            assert specs[name].min_us <= position <= specs[name].max_us


# --- profiles ----------------------------------------------------------------------------------

PROFILE_TEXTS = [resolve_profile(name).read_text() for name in available_profiles()]
PROFILE_TREES = [tomllib.loads(text) for text in PROFILE_TEXTS]


def test_profiles_load_or_raise_profile_error() -> None:
    target = "profiles.parse_profile"

    @FUZZ
    @given(
        st.one_of(
            st.sampled_from(PROFILE_TREES).flatmap(lambda tree: mutated(tree)).map(to_toml),
            st.sampled_from(PROFILE_TREES).flatmap(lambda tree: mutated(tree)).map(to_toml),
            st.sampled_from(PROFILE_TEXTS).flatmap(damaged_text),
            st.text(max_size=200),
        )
    )
    def case(text: str) -> None:
        profile = outcome(target, lambda: parse_profile(text), ProfileError)
        if profile is not None:
            drive(profile)

    case()
    check_tally(target, "valid", "refused")


# --- calibrations ------------------------------------------------------------------------------

CALIBRATION: dict[str, Any] = {
    "name": "ann",
    "neutral": [0.5 + i / 100 for i in range(68)],
    "delta_min": [-0.01 * (i % 5) - 0.01 for i in range(68)],
    "delta_max": [0.02 * (i % 7) + 0.01 for i in range(68)],
    "created": "2026-01-01T00:00:00Z",
    "named_neutral": {"jaw_open": 0.1, "head_yaw": 0.0},
    "named_min": {"jaw_open": -0.2, "head_yaw": -30.0},
    "named_max": {"jaw_open": 0.6, "head_yaw": 30.0},
}
CALIBRATION_JSON = to_json(CALIBRATION)
PAPER16 = parse_profile(resolve_profile("paper16").read_text())
HEAD16 = parse_profile(resolve_profile("head16").read_text())


def test_calibrations_load_or_raise_calibration_error() -> None:
    target = "calibration.parse_calibration"

    @FUZZ
    @given(
        st.one_of(
            mutated(CALIBRATION).map(to_json),
            mutated(CALIBRATION).map(to_json),
            damaged(CALIBRATION_JSON),
            st.binary(max_size=100),
        )
    )
    def case(data: bytes) -> None:
        calibration = outcome(target, lambda: parse_calibration(data), CalibrationError)
        if calibration is None:
            return
        drive(PAPER16, calibration)
        drive(HEAD16, calibration)
        features = FeatureProcessor(calibration=calibration).process(POINTS)
        codec.decode(codec.encode(features), Features)  # what F publishes is valid

    case()
    check_tally(target, "valid", "refused")


# --- graphs ------------------------------------------------------------------------------------

GRAPH_FILES = [
    ROOT / "facesynth/app/graphs/demo.toml",
    ROOT / "facesynth/app/graphs/face.toml",
    ROOT / "deploy/graph.toml",
]
GRAPH_TEXTS = [path.read_text() for path in GRAPH_FILES]
GRAPH_TREES = [tomllib.loads(text) for text in GRAPH_TEXTS]


def test_graphs_load_or_raise_graph_error() -> None:
    target = "graph.load_graph"
    folder = scratch_folder("fuzz-graph-")
    file = folder / "graph.toml"

    @FUZZ
    @given(
        st.one_of(
            st.sampled_from(GRAPH_TREES).flatmap(lambda tree: mutated(tree)).map(to_toml),
            st.sampled_from(GRAPH_TREES).flatmap(lambda tree: mutated(tree)).map(to_toml),
            st.sampled_from(GRAPH_TEXTS).flatmap(damaged_text),
            st.text(max_size=200),
        )
    )
    def case(text: str) -> None:
        file.write_text(text, encoding="utf-8", errors="surrogatepass")
        outcome(target, lambda: load_graph(file), GraphError)

    case()
    check_tally(target, "valid", "refused")


# --- F's learned state -------------------------------------------------------------------------

STATE: dict[str, Any] = msgspec.to_builtins(
    LearnedState(
        rig="default",
        performer="ann",
        updated_ns=1_700_000_000_000_000_000,
        neutral=[0.5 + i / 100 for i in range(68)],
        frame=[float(v) for v in np.linspace(-1.0, 1.0, 136)],
        named_neutral={"jaw_open": 0.1},
        ranges={"jaw_open": (-0.2, 0.6), "head_yaw": (-30.0, 30.0)},
    )
)
STATE_JSON = to_json(STATE)


def test_learned_state_loads_or_raises_state_error() -> None:
    target = "features.state.parse_state"

    @FUZZ
    @given(
        st.one_of(
            mutated(STATE).map(to_json),
            mutated(STATE).map(to_json),
            damaged(STATE_JSON),
            st.binary(max_size=100),
        )
    )
    def case(data: bytes) -> None:
        state = outcome(target, lambda: parse_state(data), StateError)
        if state is None:
            return
        processor = FeatureProcessor()
        restore(processor, state)
        features = processor.process(POINTS)
        codec.decode(codec.encode(features), Features)  # what F publishes is valid

    case()
    check_tally(target, "valid", "refused")
