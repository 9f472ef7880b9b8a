"""Head files: the bundled heads, and one clear error line for every bad file."""

from __future__ import annotations

from pathlib import Path

import pytest

from facesynth.app.simhead import EFFECTS, HeadError, head_names, load_head, parse_head
from facesynth.runtime.profiles import load_profile

GOOD = """
name = "tiny"
[[actuators]]
name = "jaw"
channel = 3
rest_us = 1520
effects = { jaw = 1.0 }
"""


def test_the_bundled_heads_load() -> None:
    assert {"simhead16", "simhead16_reversed", "simhead16_stiff"} <= set(head_names())
    for name in head_names():
        head = load_head(name)
        assert head.name == name
        assert len(head.actuators) == (18 if name.startswith("simhead18") else 16)


@pytest.mark.parametrize(
    "head",
    ["simhead16", "simhead16_reversed", "simhead16_stiff", "simhead18_lids", "simhead18_neck"],
)
@pytest.mark.parametrize("profile", ["paper16", "head16", "head16_bs"])
def test_the_heads_are_wired_like_paper16(head: str, profile: str) -> None:
    """Same servo names, channels and pulse limits, so the shipped profiles drive them."""
    actuators = load_head(head).by_channel()
    for spec in load_profile(profile).servos:
        actuator = actuators[spec.channel]
        assert actuator.name == spec.name
        assert spec.min_us <= actuator.rest_us <= spec.max_us


@pytest.mark.parametrize(
    ("head", "profile", "effects"),
    [
        ("simhead18_lids", "head18_lids_hardware", {"blink_right", "blink_left"}),
        ("simhead18_neck", "head18_neck_hardware", {"neck_yaw", "neck_pitch"}),
    ],
)
def test_the_heads_with_lids_and_a_neck_are_simhead16_and_two_actuators(
    head: str, profile: str, effects: set[str]
) -> None:
    """Channels 0-15 as simhead16; 16 and 17 drive the new effects, wired as the head's
    hardware profile says (same names and channels, rests within its limits)."""
    actuators = load_head(head).by_channel()
    base = load_head("simhead16").by_channel()
    assert all(actuators[channel] == base[channel] for channel in range(16))
    assert {e for channel in (16, 17) for e in actuators[channel].effects} == effects
    specs = load_profile(profile).servos
    assert [s.channel for s in specs] == list(range(18))
    for spec in specs:
        actuator = actuators[spec.channel]
        assert actuator.name == spec.name
        assert spec.min_us <= actuator.rest_us <= spec.max_us


def test_the_other_heads_differ_as_promised() -> None:
    reversed_head = load_head("simhead16_reversed").by_channel()
    assert reversed_head[0].reversed and reversed_head[1].reversed
    assert not reversed_head[2].effects  # a dead channel
    assert reversed_head[13].dead_band_us >= 100  # a wide dead band
    stiff = load_head("simhead16_stiff").by_channel()
    assert not stiff[15].effects
    assert stiff[4].dead_band_us >= 100
    default = load_head("simhead16").by_channel()
    assert all(a.effects for a in default.values())
    assert any(a.rest_us != 1500 for a in default.values())
    assert any(a.coupling for a in default.values())
    assert {a.curve for a in default.values()} >= {"power", "smoothstep"}


def test_a_head_by_path(tmp_path: Path) -> None:
    path = tmp_path / "tiny.toml"
    path.write_text(GOOD)
    head = load_head(path)
    assert head.by_channel()[3].rest_us == 1520
    assert load_head(str(path)) == head


BAD = [
    ("not toml", "name = \n", "not valid TOML"),
    ("no actuators", 'name = "x"\nactuators = []\n', "at least one actuator"),
    ("unknown field", GOOD + "wheels = 4\n", "unknown field `wheels`"),
    ("unknown actuator field", GOOD.replace("rest_us", "rest"), "unknown field `rest`"),
    ("wrong type", GOOD.replace("channel = 3", 'channel = "3"'), "Expected `int`"),
    ("channel too high", GOOD.replace("channel = 3", "channel = 24"), "<= 23"),
    ("unknown effect", GOOD.replace("jaw = 1.0", "jaws = 1.0"), "unknown effect 'jaws'"),
    ("huge amount", GOOD.replace("jaw = 1.0", "jaw = 9.0"), "beyond +-3"),
    ("rest outside", GOOD.replace("rest_us = 1520", "rest_us = 2100"), "rest_us 2100 must be"),
    ("inverted range", GOOD + "min_us = 2000\nmax_us = 1000\n", "must be below max_us"),
    ("dead band", GOOD + "dead_band_us = 600\n", "leaves no travel"),
    ("bad curve", GOOD + 'curve = "cubic"\n', "Invalid enum value 'cubic'"),
    ("zero slew", GOOD + "slew_us_per_s = 0\n", "> 0"),
    (
        "two on a channel",
        GOOD + '[[actuators]]\nname = "other"\nchannel = 3\n',
        "channel 3 is also 'jaw'",
    ),
    ("pulse out of range", GOOD + "max_us = 4000\n", "<= 2500"),
    # Found by fuzzing: msgspec quotes a key as it is, and a TOML key may hold a newline.
    ("key with a newline", GOOD + '"gain\\nup" = 1.0\n', "unknown field `gain\\nup`"),
]


@pytest.mark.parametrize(("case", "text", "message"), BAD, ids=[c[0] for c in BAD])
def test_a_bad_head_is_one_clear_error(case: str, text: str, message: str) -> None:
    with pytest.raises(HeadError, match=r"^head: ") as info:
        parse_head(text)
    assert message in str(info.value)
    assert "\n" not in str(info.value)


def test_bad_names_and_files(tmp_path: Path) -> None:
    with pytest.raises(HeadError, match="unknown head 'nohead' \\(available: simhead16"):
        load_head("nohead")
    with pytest.raises(HeadError, match="does not exist"):
        load_head(tmp_path / "missing.toml")
    binary = tmp_path / "binary.toml"
    binary.write_bytes(b"\xff\xfe\x00")
    with pytest.raises(HeadError, match="not valid TOML"):
        load_head(binary)
    with pytest.raises(HeadError, match="does not exist"):
        load_head(tmp_path)  # a folder


def test_every_effect_is_named_once() -> None:
    assert len(set(EFFECTS)) == len(EFFECTS) >= 19
