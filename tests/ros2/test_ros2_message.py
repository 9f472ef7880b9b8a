"""The ``ros2`` driver's message: one per driver, refilled at each command (a fresh 16-joint
JointState cost 80-90 µs per command at 30 Hz here, a refilled one 25-30 µs), its angles the
``array('d')`` rclpy keeps them in. What each command's message carries is read back through
rclpy's own serializer and deserializer, so refilling never changes one already sent."""

from __future__ import annotations

from array import array
from typing import Any

import pytest

from facesynth.runtime.profiles import load_profile
from facesynth.services.control.drivers.ros2 import Output, Ros2Config, Ros2Driver

PROFILE = load_profile("paper16")
STAMP_NS = 1_764_000_000_123_456_789


def angles(value: float) -> list[float]:
    return [value + 0.01 * index for index in range(len(PROFILE.servos))]


def wire(msg: Any) -> Any:
    """``msg`` as a subscriber gets it: serialized by rclpy, deserialized again."""
    from rclpy.serialization import deserialize_message, serialize_message

    return deserialize_message(serialize_message(msg), type(msg))


def positions(output: Output, msg: Any) -> Any:
    return {
        "joint_state": lambda: msg.position,
        "trajectory": lambda: msg.points[0].positions,
        "array": lambda: msg.data,
    }[output]()


@pytest.mark.parametrize("output", ["joint_state", "trajectory", "array"])
def test_each_command_refills_the_one_message(output: Output) -> None:
    driver = Ros2Driver(Ros2Config(output=output), PROFILE)
    first = driver.message(angles(0.5), STAMP_NS)
    sent = wire(first)
    second = driver.message(angles(1.5), STAMP_NS + 33_000_000)
    assert second is first
    assert isinstance(positions(output, second), array)
    assert positions(output, second).typecode == "d"
    assert list(positions(output, sent)) == pytest.approx(angles(0.5))
    assert list(positions(output, wire(second))) == pytest.approx(angles(1.5))
    if output != "array":
        assert (sent.header.stamp.sec, sent.header.stamp.nanosec) == divmod(STAMP_NS, 10**9)
        stamp = wire(second).header.stamp
        assert stamp.sec * 10**9 + stamp.nanosec == STAMP_NS + 33_000_000


def test_what_every_command_shares_is_set_once() -> None:
    joints = Ros2Driver(Ros2Config(), PROFILE).message(angles(0.5), STAMP_NS)
    assert list(wire(joints).name) == [spec.name for spec in PROFILE.servos]
    trajectory = Ros2Driver(Ros2Config(output="trajectory", time_from_start=1.25), PROFILE)
    for value in (0.5, 1.5):
        msg = wire(trajectory.message(angles(value), STAMP_NS))
        assert list(msg.joint_names) == [spec.name for spec in PROFILE.servos]
        assert len(msg.points) == 1
        point = msg.points[0].time_from_start
        assert (point.sec, point.nanosec) == (1, 250_000_000)
