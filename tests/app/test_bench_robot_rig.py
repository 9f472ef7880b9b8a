"""``facesynth bench robot``'s head outside this process (facesynth/app/bench/robot_outside.py),
from the same flags as ``facesynth learn`` takes (:mod:`facesynth.app.learn.babble_flags`): any
servo driver with its options, the camera watching the head on any live source, and the head's
name in the report."""

from __future__ import annotations

from pathlib import Path

import pytest

from facesynth.app.arguments import OptionError
from facesynth.app.bench.robot_outside import head_rig
from facesynth.app.cli import build_parser
from facesynth.app.learn.babble_flags import rig_configs
from facesynth.app.robot_rig import newest

LEARN = ["learn", "--profile", "head16_hardware", "--out", "s.mcap"]
BENCH = ["bench", "robot", "--profile", "s16.learned"]

RIGS = [
    (
        # A Pi's PCA9685 on I2C, the head's camera on a ROS 2 topic.
        ["--ros2-image-topic", "/head/image_raw", "--driver", "pca9685", "--i2c-bus", "1"],
        "pca9685 1 | ros2 /head/image_raw",
        {"address": "0x40", "bus": "1"},
    ),
    (
        # Dynamixel protocol 1 at 57,600 baud, a USB camera at 640 x 480.
        [
            *("--camera", "0", "--width", "640", "--height", "480"),
            *("--driver", "dynamixel", "--port", "/dev/ttyUSB0"),
            *("--dynamixel-protocol", "1", "--baud", "57600"),
        ],
        "dynamixel /dev/ttyUSB0 | camera 0",
        {"protocol": 1, "baud": 57600},
    ),
    (
        # A Feetech bus, an MJPEG stream.
        [
            *("--camera", "http://10.0.0.2:8080/video.mjpg"),
            *("--driver", "feetech", "--port", "/dev/ttyUSB1", "--bus-read-hz", "5"),
        ],
        "feetech /dev/ttyUSB1 | camera http://10.0.0.2:8080/video.mjpg",
        {"read_hz": 5.0},
    ),
    (
        # A Mini Maestro 24 told its model and to send no speed limits.
        [
            *("--camera", "/dev/video2", "--driver", "maestro", "--port", "/dev/ttyACM0"),
            *("--maestro-model", "mini24", "--no-maestro-speed-limits"),
        ],
        "maestro /dev/ttyACM0 | camera /dev/video2",
        {"model": "mini24", "speed_limits": False},
    ),
]


@pytest.mark.parametrize(("rig", "name", "driver_fields"), RIGS)
def test_bench_robot_builds_learns_rig_from_the_same_flags(
    rig: list[str], name: str, driver_fields: dict[str, object]
) -> None:
    camera, driver, named = head_rig(build_parser().parse_args([*BENCH, *rig]))
    learned = rig_configs(build_parser().parse_args([*LEARN, *rig]), Path("x.jsonl"))
    # learn's camera keeps its newest frame unless told not to; bench's feed does that itself
    assert (newest(camera), driver) == (learned["sensor"], learned["control"])
    assert named == name
    for field, value in driver_fields.items():
        assert getattr(driver, field) == value, field


@pytest.mark.parametrize(
    ("rig", "message"),
    [
        (["--driver", "maestro"], "needs both --driver and --camera"),
        (["--camera", "0"], "needs both --driver and --camera"),
        (["--driver", "maestro", "--camera", "0", "--head", "simhead16"], "--head names"),
        (["--driver", "maestro", "--camera", "0", "--i2c-bus", "1"], "does not apply to driver"),
    ],
)
def test_an_incomplete_or_mixed_rig_is_a_clear_error(rig: list[str], message: str) -> None:
    with pytest.raises(OptionError, match=message):
        head_rig(build_parser().parse_args([*BENCH, *rig]))
