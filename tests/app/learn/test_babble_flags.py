"""The robot's rig from the command line, declared once (``babble_flags``): ``facesynth learn``
and ``facesynth plan``'s rehearsal take the same camera sources, tracker and servo drivers with
every one's options, and turn them into the same checked configs."""

from __future__ import annotations

from pathlib import Path

import pytest

from facesynth.app.arguments import OptionError
from facesynth.app.cli import build_parser
from facesynth.app.learn.babble_flags import camera_given, rig_configs, rig_flags_given
from facesynth.services.sensor.sources.camera import CameraConfig

LEARN = ["learn", "--profile", "head16_hardware", "--out", "s.mcap"]
PLAN = ["plan", "v.mp4", "--profile", "s16.learned", "--out", "p.mcap"]
RECORD = Path("x.commands.jsonl")

RIGS = [
    (
        # A Pi's PCA9685 on I2C, the head's camera on a ROS 2 topic.
        ["--ros2-image-topic", "/head/image_raw", "--driver", "pca9685", "--i2c-bus", "1"],
        {"sensor": {"topic": "/head/image_raw"}, "control": {"bus": "1", "address": "0x40"}},
    ),
    (
        # Dynamixel protocol 1 at 57,600 baud, a USB camera, the fast tracker model.
        [
            *("--camera", "0", "--model", "fast"),
            *("--driver", "dynamixel", "--port", "/dev/ttyUSB0"),
            *("--dynamixel-protocol", "1", "--baud", "57600"),
        ],
        {"points": {"model": "fast"}, "control": {"protocol": 1, "baud": 57600}},
    ),
    (
        # A Mini Maestro 24 told its model, an MJPEG stream.
        [
            *("--camera", "http://10.0.0.2:8080/video.mjpg", "--driver", "maestro"),
            *("--port", "/dev/ttyACM0", "--maestro-model", "mini24"),
        ],
        {"sensor": {"newest": True}, "control": {"model": "mini24", "port": "/dev/ttyACM0"}},
    ),
]


@pytest.mark.parametrize(("rig", "expected"), RIGS)
def test_learn_and_plan_build_the_same_rig_from_the_same_flags(
    rig: list[str], expected: dict[str, dict[str, object]]
) -> None:
    learn = rig_configs(build_parser().parse_args([*LEARN, *rig]), RECORD)
    plan = rig_configs(build_parser().parse_args([*PLAN, *rig]), RECORD)
    assert learn == plan
    for stage, fields in expected.items():
        for field, value in fields.items():
            assert getattr(plan[stage], field) == value, (stage, field)


def test_a_camera_keeps_its_newest_frame_unless_told_otherwise() -> None:
    camera = ["--camera", "0", "--driver", "maestro", "--port", "/dev/ttyACM0"]
    newest = rig_configs(build_parser().parse_args([*PLAN, *camera]), RECORD)["sensor"]
    every = rig_configs(build_parser().parse_args([*PLAN, *camera, "--no-newest-frame"]), RECORD)[
        "sensor"
    ]
    assert isinstance(newest, CameraConfig) and isinstance(every, CameraConfig)
    assert newest.newest and not every.newest


def test_the_record_driver_writes_where_the_command_says() -> None:
    args = build_parser().parse_args([*LEARN, "--video", "v.mp4"])
    assert rig_configs(args, RECORD)["control"].out == str(RECORD)  # type: ignore[attr-defined]


def test_no_camera_and_stray_options_are_clear_errors() -> None:
    bare = build_parser().parse_args([*PLAN, "--driver", "maestro"])
    assert not camera_given(bare)
    with pytest.raises(OptionError, match="give the robot's camera with --camera"):
        rig_configs(bare, RECORD)
    stray = build_parser().parse_args(
        [*PLAN, "--camera", "0", "--driver", "maestro", "--i2c-bus", "1"]
    )
    with pytest.raises(OptionError, match="--i2c-bus does not apply to driver maestro"):
        rig_configs(stray, RECORD)


def test_the_rig_flags_given_are_named() -> None:
    assert rig_flags_given(build_parser().parse_args(PLAN)) == []
    args = build_parser().parse_args([*PLAN, "--port", "/dev/ttyACM0", "--camera", "0"])
    assert rig_flags_given(args) == ["--camera", "--port"]
