"""The ``ros2`` driver: every command C sends, published to a ROS 2 graph.

One message per command, in one of three forms (``--ros2-output``):

* ``joint_state`` (default): a ``sensor_msgs/msg/JointState`` on ``/facesynth/joint_commands``,
  ``name`` the profile's servo names, ``position`` their angles in radians;
* ``trajectory``: a ``trajectory_msgs/msg/JointTrajectory`` with one point reached
  ``--ros2-time-from-start`` seconds later, on ``/joint_trajectory_controller/joint_trajectory``
  (a ros2_control ``joint_trajectory_controller``);
* ``array``: a ``std_msgs/msg/Float64MultiArray`` of the angles in the profile's servo order on
  ``/forward_position_controller/commands`` (a ros2_control ``forward_command_controller``).

Angles come from each servo's pulse -> angle map in the profile (``angle``; by default
500-2500 µs over 0-180°). The header stamp (JointState, JointTrajectory) is the capture time of
the frame the command came from (``CommandInfo.t_capture_ns``), so a subscriber can measure the
chain's latency; C's own moves (start, return to neutral, shutdown) are stamped when sent.

C keeps every safety rule (clamping, speed limits, neutral on silence and at shutdown): the
driver publishes what C sends, clamped once more to the profile's limits like every driver. The
topic and the QoS (``--ros2-reliability``, default reliable; ``--ros2-depth``, default 10) are
options. At start it waits up to ``--ros2-wait`` seconds (default 5) for a subscriber to be
discovered (Fast DDS took 2-3 s on this project's machine), so the first commands are not lost
to discovery. On close it waits (at most ``CLOSE_WAIT_S``) until the subscribers acknowledged the
last message, so the neutral C sends at shutdown reaches them.

rclpy comes with the ``[ros2]`` extra and is imported only when this driver is built.
"""

from __future__ import annotations

import asyncio
import time
from array import array
from collections.abc import Mapping
from typing import Annotated, Any, Final, Literal

import msgspec

from facesynth.runtime.profiles import Profile
from facesynth.runtime.ros2 import Reliability, Ros2Node, import_ros2, qos_profile, set_stamp
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers._extras import MissingExtra
from facesynth.services.control.drivers.base import DriverConfigError, DriverError, ServoDriver
from facesynth.services.control.drivers.registry import DRIVERS
from facesynth.services.control.drivers.servo_map import ProfileLimits

Output = Literal["joint_state", "trajectory", "array"]
#: Each output's topic unless ``--ros2-topic`` names another.
DEFAULT_TOPICS: Final[dict[str, str]] = {
    "joint_state": "/facesynth/joint_commands",
    "trajectory": "/joint_trajectory_controller/joint_trajectory",
    "array": "/forward_position_controller/commands",
}
#: How long :meth:`Ros2Driver.close` waits for the subscribers to acknowledge the last message.
CLOSE_WAIT_S: Final = 1.0


class Ros2Config(
    msgspec.Struct, tag="ros2", tag_field="driver", kw_only=True, forbid_unknown_fields=True
):
    """Publish every command to ROS 2: a JointState, a JointTrajectory or a Float64MultiArray."""

    output: Annotated[
        Output,
        msgspec.Meta(
            description="joint_state (sensor_msgs/JointState, default), trajectory "
            "(trajectory_msgs/JointTrajectory, one point) or array (std_msgs/Float64MultiArray "
            "in the profile's servo order)",
            extra={"flag": "--ros2-output"},
        ),
    ] = "joint_state"
    topic: Annotated[
        str,
        msgspec.Meta(
            description="topic (default: /facesynth/joint_commands; trajectory: "
            "/joint_trajectory_controller/joint_trajectory; array: "
            "/forward_position_controller/commands)",
            extra={"flag": "--ros2-topic"},
        ),
    ] = ""
    reliability: Annotated[
        Reliability,
        msgspec.Meta(
            description="QoS reliability: reliable (default) or best_effort",
            extra={"flag": "--ros2-reliability"},
        ),
    ] = "reliable"
    depth: Annotated[
        int,
        msgspec.Meta(
            ge=1,
            le=1000,
            description="QoS depth (keep last; default 10)",
            extra={"flag": "--ros2-depth"},
        ),
    ] = 10
    node: Annotated[
        str,
        msgspec.Meta(
            description="ROS 2 node name (default facesynth_control)", extra={"flag": "--ros2-node"}
        ),
    ] = "facesynth_control"
    wait: Annotated[
        float,
        msgspec.Meta(
            ge=0,
            le=60,
            description="seconds to wait at start for a subscriber to be discovered, so the "
            "first commands are not lost (default 5; 0: do not wait)",
            extra={"flag": "--ros2-wait"},
        ),
    ] = 5.0
    time_from_start: Annotated[
        float,
        msgspec.Meta(
            ge=0,
            le=60,
            description="trajectory: seconds to reach the point (default 0.05)",
            extra={"flag": "--ros2-time-from-start"},
        ),
    ] = 0.05


def angles(profile: Profile, positions: Mapping[str, float]) -> list[float]:
    """The radians of every servo of ``profile``, in its order, from ``positions`` (µs)."""
    return [spec.angle.radians(positions[spec.name]) for spec in profile.servos]


@DRIVERS.register(Ros2Config)
class Ros2Driver(ServoDriver):
    """Publish each command (radians, from the profile's angle maps) on a ROS 2 topic."""

    #: A ROS 2 head is a real one: speed limits are measured in real time.
    moves_hardware = True
    needs_extra = "ros2"

    def __init__(self, config: Ros2Config, profile: Profile | None = None) -> None:
        if profile is None:
            raise DriverConfigError("the ros2 driver needs a profile (its servo names and angles)")
        self.config = config
        self.profile = profile
        self.topic = config.topic or DEFAULT_TOPICS[config.output]
        modules = {
            "joint_state": "sensor_msgs.msg",
            "trajectory": "trajectory_msgs.msg",
            "array": "std_msgs.msg",
        }
        _, self._msgs = import_ros2(MissingExtra, "ros2 driver", modules[config.output])
        from rclpy.exceptions import InvalidNodeNameException, InvalidTopicNameException
        from rclpy.validate_node_name import validate_node_name
        from rclpy.validate_topic_name import validate_topic_name

        try:
            validate_topic_name(self.topic)
        except InvalidTopicNameException as exc:
            raise DriverConfigError(f"--ros2-topic {self.topic!r}: {_reason(exc)}") from None
        try:
            validate_node_name(config.node)
        except InvalidNodeNameException as exc:
            raise DriverConfigError(f"--ros2-node {config.node!r}: {_reason(exc)}") from None
        self.limits = ProfileLimits(profile)
        self.names = [spec.name for spec in profile.servos]
        #: Every servo's last position (µs): a command naming some servos moves those only.
        self.held = profile.neutral_positions()
        self.count = 0
        self._ros: Ros2Node | None = None
        self._publisher: Any = None
        self._message: Any = None

    async def connect(self) -> None:
        ros = await asyncio.to_thread(Ros2Node, self.config.node, DriverError)
        kind = {
            "joint_state": "JointState",
            "trajectory": "JointTrajectory",
            "array": "Float64MultiArray",
        }[self.config.output]
        qos = qos_profile(self.config.reliability, self.config.depth)
        self._publisher = ros.node.create_publisher(getattr(self._msgs, kind), self.topic, qos)
        self._ros = ros
        self.count = 0
        deadline = time.monotonic() + self.config.wait
        while self._publisher.get_subscription_count() == 0 and time.monotonic() < deadline:
            await asyncio.sleep(0.02)  # discovery: what is sent before it is lost

    async def send(self, positions: Mapping[str, float], info: CommandInfo) -> None:
        if self._publisher is None:
            raise DriverError("ros2 driver is not connected")
        self.held.update(self.limits.clamp(positions))
        stamp = info.t_capture_ns
        if stamp is None:
            stamp = info.t_ns if info.t_ns is not None else time.time_ns()
        self._publisher.publish(self.message(angles(self.profile, self.held), stamp))
        self.count += 1

    def message(self, radians: list[float], stamp_ns: int) -> Any:
        """The message of one command (angles in the profile's order).

        It is the driver's one message, built at the first command and refilled at each: rclpy
        copies a message into the middleware's own when it publishes, so refilling it never
        changes one sent. The angles go in as the ``array('d')`` rclpy keeps them in (its
        setters take one as it is, even when checking fields). Building a fresh JointState of
        16 joints took 80-90 µs per command at 30 Hz on this project's machine, refilling one
        25-30 µs."""
        msg = self._message
        if msg is None:
            msg = self._message = self._blank()
        positions = array("d", radians)
        output = self.config.output
        if output == "joint_state":
            set_stamp(msg.header.stamp, stamp_ns)
            msg.position = positions
        elif output == "trajectory":
            set_stamp(msg.header.stamp, stamp_ns)
            msg.points[0].positions = positions
        else:
            msg.data = positions
        return msg

    def _blank(self) -> Any:
        """The message :meth:`message` refills: what every command shares set once."""
        msgs = self._msgs
        output = self.config.output
        if output == "joint_state":
            msg = msgs.JointState()
            msg.name = list(self.names)
            return msg
        if output == "trajectory":
            msg = msgs.JointTrajectory()
            msg.joint_names = list(self.names)
            point = msgs.JointTrajectoryPoint()
            seconds, nanoseconds = divmod(round(self.config.time_from_start * 1e9), 1_000_000_000)
            point.time_from_start.sec, point.time_from_start.nanosec = seconds, nanoseconds
            msg.points = [point]
            return msg
        return msgs.Float64MultiArray()

    async def close(self) -> None:
        ros, publisher = self._ros, self._publisher
        self._ros = self._publisher = None
        if ros is None:
            return
        await asyncio.to_thread(_flush_and_close, ros, publisher)

    def state(self) -> str:
        return f"{self.count} sent on {self.topic}" if self._ros is not None else ""


def _flush_and_close(ros: Ros2Node, publisher: Any) -> None:
    from rclpy.duration import Duration

    try:
        publisher.wait_for_all_acked(Duration(nanoseconds=round(CLOSE_WAIT_S * 1e9)))
    finally:
        ros.close()


def _reason(exc: Exception) -> str:
    """rclpy's reason for an invalid name, without its caret line."""
    text = str(exc).splitlines()
    return " ".join(text[0].split()).rstrip(":") if text else type(exc).__name__
