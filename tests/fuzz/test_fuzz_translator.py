"""Fuzz the translator with decoded feature streams: every shipped profile, every position it
outputs finite and within the profile's limits, and its commands accepted by the control core."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import msgspec
import pytest
from fuzzing import FUZZ, TIMEOUT, check_tally, outcome
from hypothesis import given
from hypothesis import strategies as st
from mutations import damaged, mutated

from facesynth.runtime import codec
from facesynth.runtime.profiles import Profile, available_profiles, load_profile
from facesynth.schemas.messages import Features, ServoCommands
from facesynth.services.control.core import Arrival, CommandError, ControlCore, StaleCommand
from facesynth.services.translator.core import Translator

pytestmark = [pytest.mark.fuzz, TIMEOUT]

PROFILES = {name: load_profile(name) for name in available_profiles()}
FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "messages" / "features.msgpack"


def _sources(profile: Profile) -> set[str]:
    names: set[str] = set()
    for spec in profile.servos:
        names |= {n for n in (spec.feature, spec.blendshape) if n}
        names |= set(spec.weights() or {})
    return names


#: The golden features message, with every named source of every shipped profile in it.
SEED: dict[str, Any] = msgspec.msgpack.decode(FIXTURE.read_bytes())
SEED["named"] = {
    **SEED["named"],
    **{name: 0.5 for profile in PROFILES.values() for name in sorted(_sources(profile))},
}
SEED_BYTES = msgspec.msgpack.encode(SEED)


_PROFILE_NAMES = st.sampled_from(sorted(PROFILES))
_PAYLOAD_COUNTS = st.integers(1, 4)
_KINDS = st.sampled_from(["mutated", "valid", "damaged", "random"])
_DAMAGED = damaged(SEED_BYTES)
_RANDOM = st.binary(max_size=32)


@st.composite
def feature_streams(draw: st.DrawFn) -> tuple[str, list[bytes]]:
    """A shipped profile's name and 1..4 feature payloads: the seed at 30 fps with its times
    and values mutated (times may jump, go back or stand still), damaged, or random."""
    profile = draw(_PROFILE_NAMES)
    payloads = []
    for index in range(draw(_PAYLOAD_COUNTS)):
        tree = dict(SEED, seq=index, t_media_ns=index * 33_333_333)
        tree["face"] = draw(st.booleans()) or index > 0
        # one of four kinds, as st.one_of picks them, but only the one picked built
        kind = draw(_KINDS)
        if kind == "mutated":
            payload = msgspec.msgpack.encode(draw(mutated(tree, max_changes=2)))
        elif kind == "valid":
            payload = msgspec.msgpack.encode(tree)
        else:
            payload = draw(_DAMAGED if kind == "damaged" else _RANDOM)
        payloads.append(payload)
    return profile, payloads


def test_translator_positions_stay_within_the_profile_limits() -> None:
    target = "Translator.step (features)"
    core_target = "ControlCore.command (translator)"

    @FUZZ
    @given(feature_streams())
    def case(stream: tuple[str, list[bytes]]) -> None:
        name, payloads = stream
        profile = PROFILES[name]
        specs = {spec.name: spec for spec in profile.servos}
        translator = Translator(profile)
        core = ControlCore(profile, motion_time="media")
        core.start(0)
        for index, payload in enumerate(payloads):
            features = outcome(
                target, lambda p=payload: codec.decode(p, Features), codec.MessageError
            )
            if features is None:
                continue
            commands = translator.translate(features)
            assert set(commands.positions) == set(specs)
            for servo, value in commands.positions.items():
                spec = specs[servo]
                assert math.isfinite(value) and spec.min_us <= value <= spec.max_us, (
                    servo,
                    value,
                )
            wire = codec.decode(codec.encode(commands), ServoCommands)
            mono = (index + 1) * 33_000_000
            applied = outcome(
                core_target,
                lambda c=wire, m=mono: core.command(c, Arrival(wall_ns=m, mono_ns=m)),
                (CommandError, StaleCommand),
            )
            if applied is not None:
                for servo, value in applied[0].positions.items():
                    assert specs[servo].min_us <= value <= specs[servo].max_us

    case()
    check_tally(target, "valid", "refused")
    check_tally(core_target, "valid", every_case=False)
