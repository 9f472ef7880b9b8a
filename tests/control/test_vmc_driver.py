"""services.control.drivers.vmc: blendshapes and head pose as VMC, checked by a real OSC server."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import pytest

from facesynth.runtime.plugins import PluginError
from facesynth.runtime.profiles import Profile, load_profile
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers.base import DriverError
from facesynth.services.control.drivers.registry import DRIVERS
from facesynth.services.control.drivers.vmc import (
    ARKIT52,
    VIRTUAL_TO_ARKIT,
    AvatarMapping,
    VmcConfig,
    VmcDriver,
    VmcError,
    unity_quaternion,
)
from tests.control.osc_receiver import osc_receiver

INFO = CommandInfo(1, None, True)


def arkit_profile(tmp_path: Path, names: tuple[str, ...] = ARKIT52) -> Profile:
    """An ``arkit52``-style profile: one control per blendshape, 0..1000, neutral 0."""
    lines = ['name = "arkit-test"', 'scheme = "ibug68"']
    for channel, name in enumerate(names):
        lines += [
            "[[servos]]",
            f'name = "{name}"',
            f"channel = {channel}",
            'feature = "jaw_open"',
            "min_us = 0",
            "neutral_us = 0",
            "max_us = 1000",
        ]
    path = tmp_path / "arkit.toml"
    path.write_text("\n".join(lines))
    return load_profile(str(path))


def test_arkit52_has_the_52_distinct_names() -> None:
    assert len(ARKIT52) == len(set(ARKIT52)) == 52
    mapped = {shape for ups, downs in VIRTUAL_TO_ARKIT.values() for shape in (*ups, *downs)}
    assert mapped <= set(ARKIT52)
    assert set(VIRTUAL_TO_ARKIT) <= {s.name for s in load_profile("virtual").servos}


def test_unity_quaternions() -> None:
    s = math.sqrt(0.5)
    assert unity_quaternion(0, 0, 0) == pytest.approx((0, 0, 0, 1))
    assert unity_quaternion(0, 90, 0) == pytest.approx((0, s, 0, s))
    assert unity_quaternion(90, 0, 0) == pytest.approx((s, 0, 0, s))
    assert unity_quaternion(0, 0, -90) == pytest.approx((0, 0, -s, s))
    # Unity applies z, then x, then y: Euler(90, 90, 0) = y(90) * x(90).
    assert unity_quaternion(90, 90, 0) == pytest.approx((0.5, 0.5, -0.5, 0.5))
    for angles in ((10, 20, 30), (-45, 170, 5)):
        assert sum(c * c for c in unity_quaternion(*angles)) == pytest.approx(1.0)


def virtual_positions(**controls: float) -> dict[str, float]:
    return {**load_profile("virtual").neutral_positions(), **controls}


@pytest.mark.parametrize(
    ("controls", "expected"),
    [
        ({}, {"jawOpen": 0.0, "eyeBlinkLeft": 0.0, "eyeWideLeft": 0.0, "browInnerUp": 0.0}),
        ({"jaw": 1000.0}, {"jawOpen": 1.0}),
        ({"jaw": 250.0}, {"jawOpen": 0.25}),
        ({"lid_left": 0.0}, {"eyeBlinkLeft": 1.0, "eyeWideLeft": 0.0}),
        ({"lid_right": 750.0}, {"eyeWideRight": 0.5, "eyeBlinkRight": 0.0}),
        ({"brow_right": 1000.0}, {"browOuterUpRight": 1.0, "browInnerUp": 0.5}),
        ({"brow_left": 0.0}, {"browDownLeft": 1.0, "browInnerUp": 0.0}),
        (
            {"gaze_right_x": 1000.0, "gaze_left_x": 1000.0},  # both look to the performer's left
            {"eyeLookInRight": 1.0, "eyeLookOutLeft": 1.0, "eyeLookOutRight": 0.0},
        ),
        ({"gaze_left_y": 0.0}, {"eyeLookDownLeft": 1.0, "eyeLookUpLeft": 0.0}),
        (
            {"lip_corner_left": 1000.0, "lip_corner_right": 250.0},
            {"mouthSmileLeft": 1.0, "mouthFrownRight": 0.5},
        ),
        ({"cheek_right": 400.0}, {"cheekSquintRight": 0.4}),
        ({"lower_lip": 1000.0}, {"mouthLowerDownLeft": 1.0, "mouthLowerDownRight": 1.0}),
    ],
)
def test_virtual_controls_as_arkit_blendshapes(
    controls: dict[str, float], expected: dict[str, float]
) -> None:
    weights = AvatarMapping(load_profile("virtual")).blendshapes(virtual_positions(**controls))
    assert {name: weights[name] for name in expected} == pytest.approx(expected)
    assert all(0.0 <= v <= 1.0 for v in weights.values())


def test_head_pose_from_the_head_controls() -> None:
    mapping = AvatarMapping(load_profile("virtual"))
    assert mapping.head_degrees(virtual_positions()) == {
        "head_yaw": 0.0,
        "head_pitch": 0.0,
        "head_roll": 0.0,
    }
    degrees = mapping.head_degrees(virtual_positions(head_yaw=1000.0, head_pitch=250.0))
    assert degrees == pytest.approx({"head_yaw": 30.0, "head_pitch": -10.0, "head_roll": 0.0})
    # Turned 30 deg toward the performer's left: the avatar (facing +z) turns toward -x.
    q = mapping.head_rotation(virtual_positions(head_yaw=1000.0))
    assert q == pytest.approx(unity_quaternion(0, -30, 0))


async def test_the_virtual_profile_reaches_a_real_osc_server() -> None:
    with osc_receiver() as receiver:
        driver = VmcDriver(VmcConfig(port=receiver.port), load_profile("virtual"))
        await driver.connect()
        await driver.send(virtual_positions(jaw=1000.0, lid_left=0.0, head_roll=1000.0), INFO)
        await driver.neutral(load_profile("virtual").neutral_positions())
        await driver.close()
        assert len(receiver.wait_for("/VMC/Ext/Blend/Apply", 2)) == 2
        first = receiver.blendshapes(0)
        assert first["jawOpen"] == pytest.approx(1.0) and first["eyeBlinkLeft"] == pytest.approx(
            1.0
        )
        assert set(receiver.blendshapes(1).values()) == {0.0}  # neutral: every shape at rest
        head = receiver.wait_for("/VMC/Ext/Bone/Pos", 2)
        assert head[0][0] == "Head" and head[0][1:4] == pytest.approx((0.0, 0.08, 0.0))
        assert head[0][4:] == pytest.approx(unity_quaternion(0, 0, 25), abs=1e-6)
        assert head[1][4:] == pytest.approx((0, 0, 0, 1), abs=1e-6)
        assert receiver.wait_for("/VMC/Ext/OK", 2) == [(1,), (1,)]
        times = receiver.wait_for("/VMC/Ext/T", 2)
        assert 0.0 <= times[0][0] <= times[1][0] < 5.0
        assert driver.count == 2


async def test_an_arkit52_style_profile_sends_value_over_1000(tmp_path: Path) -> None:
    profile = arkit_profile(tmp_path)
    positions = {name: 0.0 for name in ARKIT52} | {"jawOpen": 730.0, "tongueOut": 1000.0}
    with osc_receiver() as receiver:
        driver = VmcDriver(VmcConfig(port=receiver.port), profile)
        await driver.connect()
        await driver.send(positions, INFO)
        await driver.close()
        receiver.wait_for("/VMC/Ext/Blend/Apply", 1)
        values = receiver.blendshapes()
        assert set(values) == set(ARKIT52)  # one per control, no browInnerUp made up
        assert values["jawOpen"] == pytest.approx(0.73) and values["tongueOut"] == 1.0
        assert receiver.of("/VMC/Ext/Bone/Pos") == []  # no head controls: no head bone


async def test_one_bundle_per_command_at_the_command_rate() -> None:
    with osc_receiver() as receiver:
        driver = VmcDriver(VmcConfig(port=receiver.port), load_profile("virtual"))
        await driver.connect()
        for i in range(40):
            await driver.send(virtual_positions(jaw=float(i * 25)), CommandInfo(i, None, True))
        await driver.close()
        applies = receiver.wait_for("/VMC/Ext/Blend/Apply", 40)
        assert len(applies) == 40
        assert receiver.blendshapes(-1)["jawOpen"] == pytest.approx(39 * 25 / 1000)


async def test_nobody_listening_is_not_an_error() -> None:
    with osc_receiver() as receiver:
        port = receiver.port
    driver = VmcDriver(VmcConfig(port=port), load_profile("virtual"))  # closed port
    await driver.connect()
    for _ in range(3):
        await driver.send(virtual_positions(), INFO)
    await driver.close()


def test_a_profile_with_nothing_to_send_is_refused(tmp_path: Path) -> None:
    with pytest.raises(VmcError, match="profile 'arkit-test' has no control the vmc driver can"):
        VmcDriver(VmcConfig(), arkit_profile(tmp_path, ("tail_wag", "ear_twitch")))
    # paper16 shares only its jaw with the virtual face: that one is sent, the rest ignored.
    assert AvatarMapping(load_profile("paper16")).virtual == ["jaw"]


def test_other_controls_are_ignored_and_listed(tmp_path: Path) -> None:
    profile = arkit_profile(tmp_path, ("jawOpen", "tail_wag"))
    assert AvatarMapping(profile).ignored == ["tail_wag"]


def test_an_unknown_host_is_refused() -> None:
    with pytest.raises(VmcError, match=r"--vmc-host: cannot resolve 'no\.such\.host\.invalid'"):
        VmcDriver(VmcConfig(host="no.such.host.invalid"), load_profile("virtual"))


async def test_send_before_connect_is_a_driver_error() -> None:
    driver = VmcDriver(VmcConfig(), load_profile("virtual"))
    with pytest.raises(DriverError, match="not connected"):
        await driver.send(virtual_positions(), INFO)


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"driver": "vmc", "port": 0}, "Expected `int` >= 1"),
        ({"driver": "vmc", "port": 70000}, "Expected `int` <= 65535"),
        ({"driver": "vmc", "head_position": [1.0]}, "length >= 3"),
        ({"driver": "vmc", "head_position": ["a", "b", "c"]}, "Expected `float`"),
        ({"driver": "vmc", "hots": "x"}, "unknown field `hots`"),
    ],
)
def test_bad_settings_are_refused(data: dict[str, object], message: str) -> None:
    with pytest.raises(PluginError, match=message):
        DRIVERS.parse(data)


def test_without_python_osc_the_error_names_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "pythonosc", None)
    with pytest.raises(PluginError, match=r"python-osc, which is not installed: pip install "):
        VmcDriver(VmcConfig(), load_profile("virtual"))


def test_the_shipped_arkit52_profile_goes_out_as_its_blendshapes() -> None:
    """Every arkit52 control is an ARKit name the driver sends directly (value / 1000)."""
    profile = load_profile("arkit52")
    mapping = AvatarMapping(profile)
    assert mapping.direct == [spec.name for spec in profile.servos] and not mapping.ignored
    positions = {spec.name: 0.0 for spec in profile.servos} | {"jawOpen": 640.0}
    weights = mapping.blendshapes(positions)
    assert weights["jawOpen"] == pytest.approx(0.64) and weights["mouthSmileLeft"] == 0.0
    assert set(weights) == set(ARKIT52) - {"tongueOut"}


async def test_where_it_sends_is_logged(caplog: pytest.LogCaptureFixture) -> None:
    """Issue 20: `--driver vmc` says where its UDP goes (nothing else would tell)."""
    import logging

    driver = VmcDriver(VmcConfig(host="127.0.0.1", port=39600), load_profile("virtual"))
    with caplog.at_level(logging.INFO, logger="facesynth.control"):
        await driver.connect()
    await driver.close()
    assert any("vmc: sending to 127.0.0.1:39600 over UDP" in r.getMessage() for r in caplog.records)
