"""A converted session read by ROS 2 itself: every message of the rosbag2 folder's MCAP
deserializes with rclpy's own ``deserialize_message`` into the real message classes."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
from mcap.reader import make_reader

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "app" / "recording"))

from test_rosbag2 import PROFILE, T0, pose, write_session

from facesynth.app.recording.reader import Recording
from facesynth.app.recording.rosbag2 import export_rosbag2


def test_rclpy_reads_every_message_of_a_converted_session(tmp_path: Path) -> None:
    # Imported here: `make test` collects this module without the [ros2] extra (then deselects it).
    from rclpy.serialization import deserialize_message
    from sensor_msgs.msg import CompressedImage, JointState
    from std_msgs.msg import Float32MultiArray

    types = {
        "/facesynth/joint_commands": JointState,
        "/facesynth/camera/image_raw/compressed": CompressedImage,
        "/facesynth/features": Float32MultiArray,
    }
    session, bag = tmp_path / "s.mcap", tmp_path / "bag"
    write_session(session, 4)
    with Recording(session) as recording:
        counts = export_rosbag2(recording, bag)
    read: dict[str, list[object]] = {}
    with open(bag / "bag.mcap", "rb") as handle:
        for _, channel, message in make_reader(handle).iter_messages():
            read.setdefault(channel.topic, []).append(
                deserialize_message(message.data, types[channel.topic])
            )
    assert {topic: len(items) for topic, items in read.items()} == counts
    first = read["/facesynth/joint_commands"][0]
    assert isinstance(first, JointState)
    assert first.header.stamp.sec * 1_000_000_000 + first.header.stamp.nanosec == T0
    wanted = [spec.angle.radians(pose(0)[spec.name]) for spec in PROFILE.servos]
    assert list(first.position) == pytest.approx(wanted, abs=1e-12)
