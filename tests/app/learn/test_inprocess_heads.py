"""facesynth.app.learn.inprocess, for ``bench robot --learn-poses``: a simulated head babbled in
process on the hardware profile that has its servos."""

from __future__ import annotations

import msgspec
import numpy as np
import pytest

from facesynth.app.learn.inprocess import babble_simhead, hardware_for, learn_simhead
from facesynth.app.simhead import head_names, load_head
from facesynth.runtime.feature_names import NAMES
from facesynth.runtime.profiles import load_profile


@pytest.mark.parametrize("head", [*head_names(), "seed:0", "generated:9"])
def test_each_head_babbles_on_the_hardware_profile_with_its_servos(head: str) -> None:
    config = load_head(head)
    hardware = hardware_for(config)
    assert hardware.name.endswith("_hardware")
    assert {(s.name, s.channel) for s in hardware.servos} == {
        (a.name, a.channel) for a in config.actuators
    }
    if len(config.actuators) == 16:
        assert hardware.name == "head16_hardware"


def test_a_head_no_hardware_profile_has_is_one_error_line() -> None:
    config = load_head("seed:1")
    odd = msgspec.structs.replace(config, actuators=config.actuators[:15])
    with pytest.raises(ValueError, match=r"head seed:1: no hardware profile has its servos"):
        hardware_for(odd)


def test_a_generated_head_is_babbled_and_seen() -> None:
    hardware = load_profile("head16_hardware")
    babble = babble_simhead(hardware, 4, head="seed:4", neutral_every=3)
    assert babble.kinds == ("neutral", "random", "random", "neutral")
    assert babble.inputs == NAMES and babble.servos == tuple(s.name for s in hardware.servos)
    low = np.array([s.min_us for s in hardware.servos])
    high = np.array([s.max_us for s in hardware.servos])
    assert np.all((babble.commands >= low) & (babble.commands <= high))
    assert np.all(babble.commands[0] == [s.neutral_us for s in hardware.servos])
    # The tracker finds the generated head's face in every pose (most features have a value).
    assert np.all(np.isfinite(babble.faces).mean(axis=1) > 0.8)
    # Random poses move the face from neutral.
    jaw = NAMES.index("jaw_open")
    assert np.nanmax(np.abs(babble.faces[1:3, jaw] - babble.faces[0, jaw])) > 0.005


def test_too_few_poses_are_refused() -> None:
    with pytest.raises(ValueError, match=r"--learn-poses must be at least 60 \(got 10\)"):
        learn_simhead("seed:1", 10)
