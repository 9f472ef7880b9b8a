"""Real rclpy nodes in processes of their own (started with ``spawn``): a subscriber that writes
every message it takes to a JSON-lines file, a publisher of the performer video's frames, and
a relay publishing an MJPEG stream's frames (a simulated head's camera).

They inherit the test's ``ROS_DOMAIN_ID`` and ``ROS_AUTOMATIC_DISCOVERY_RANGE``. Each is a
:class:`Peer`: started, waited for (its node is up), stopped, or killed.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import signal
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

SPAWN = multiprocessing.get_context("spawn")
#: The camera's stamps end in these nanoseconds (to the microsecond: a stamp, not a clock).
STAMP_MARK = 777
#: A reliable subscription with room for a burst (the driver's default is reliable, depth 10).
DEPTH = 100


@dataclass
class Received:
    """One message a subscriber took."""

    topic: str
    t_recv_ns: int
    stamp_ns: int | None
    names: list[str]
    positions: list[float]


def read_received(path: Path) -> list[Received]:
    """Every message in a subscriber's file (a line torn by a kill is left out)."""
    out = []
    if not path.exists():
        return out
    for line in path.read_text().splitlines():
        try:
            out.append(Received(**json.loads(line)))
        except json.JSONDecodeError:
            continue
    return out


def _subscriber(topics: dict[str, str], out: str, ready: Any, stop: Any) -> None:
    import rclpy
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray
    from trajectory_msgs.msg import JointTrajectory

    kinds = {"joint_state": JointState, "trajectory": JointTrajectory, "array": Float64MultiArray}
    rclpy.init()
    node = rclpy.create_node("test_subscriber")
    qos = QoSProfile(depth=DEPTH, reliability=ReliabilityPolicy.RELIABLE)
    with open(out, "a") as file:

        def taker(topic: str) -> Callable[[Any], None]:
            def take(msg: Any) -> None:
                now = time.time_ns()
                stamp = None
                names: list[str] = []
                if isinstance(msg, JointState):
                    names, positions = list(msg.name), list(msg.position)
                elif isinstance(msg, JointTrajectory):
                    names, positions = list(msg.joint_names), list(msg.points[0].positions)
                else:
                    positions = list(msg.data)
                if hasattr(msg, "header"):
                    stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
                record = {
                    "topic": topic,
                    "t_recv_ns": now,
                    "stamp_ns": stamp,
                    "names": names,
                    "positions": positions,
                }
                file.write(json.dumps(record) + "\n")
                file.flush()

            return take

        for topic, kind in topics.items():
            node.create_subscription(kinds[kind], topic, taker(topic), qos)
        ready.set()
        while not stop.is_set():
            rclpy.spin_once(node, timeout_sec=0.05)
    node.destroy_node()
    rclpy.shutdown()


def _publisher(
    topic: str,
    kind: str,
    encoding: str,
    fps: float,
    stamped: bool,
    behind_ns: int,
    ready: Any,
    stop: Any,
) -> None:
    import cv2
    import rclpy
    from rclpy.qos import qos_profile_sensor_data
    from sensor_msgs.msg import CompressedImage, Image

    from facesynth.app.data import sample_video

    rclpy.init()
    node = rclpy.create_node("test_camera")
    publisher = node.create_publisher(
        CompressedImage if kind == "compressed" else Image, topic, qos_profile_sensor_data
    )
    # The video is decoded (and encoded) as its frames are first sent, then looped from memory:
    # decoding it all before the first frame made the camera's start 2-4x longer (1.7-3.9 s).
    capture: Any = cv2.VideoCapture(str(sample_video()))
    frames: list[Any] = []
    encoded: list[bytes] = []
    ready.set()
    start = time.monotonic()
    index = 0
    while not stop.is_set():
        if capture is not None:
            ok, frame = capture.read()
            if ok:
                frames.append(frame)
                if kind == "compressed":
                    encoded.append(bytes(cv2.imencode(".jpg", frame)[1]))
            else:
                capture.release()
                capture = None
        due = start + index / fps
        time.sleep(max(0.0, due - time.monotonic()))
        msg: Any
        if kind == "compressed":
            msg = CompressedImage()
            msg.format = "jpeg"
            msg.data = encoded[index % len(encoded)]
        else:
            pixels = frames[index % len(frames)]
            if encoding == "rgb8":
                pixels = pixels[:, :, ::-1]
            elif encoding == "mono8":
                pixels = cv2.cvtColor(pixels, cv2.COLOR_BGR2GRAY)
            # any other encoding: BGR bytes under that name (a source must refuse it)
            msg = Image()
            msg.height, msg.width = pixels.shape[:2]
            msg.encoding = encoding
            msg.step = msg.width * (1 if encoding == "mono8" else 3)
            msg.data = pixels.tobytes()
        stamp = (time.time_ns() - behind_ns) // 1000 * 1000 + STAMP_MARK  # marked: found again
        stamp = stamp if stamped else 0
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp, 1_000_000_000)
        publisher.publish(msg)
        index += 1
    node.destroy_node()
    rclpy.shutdown()


def _relay(url: str, topic: str, ready: Any, stop: Any) -> None:
    import urllib.request

    import rclpy
    from rclpy.qos import qos_profile_sensor_data
    from sensor_msgs.msg import CompressedImage

    rclpy.init()
    node = rclpy.create_node("test_camera_relay")
    publisher = node.create_publisher(CompressedImage, topic, qos_profile_sensor_data)
    ready.set()
    buffer = b""
    with urllib.request.urlopen(url, timeout=10) as stream:
        while not stop.is_set():
            chunk = stream.read1(65536)
            if not chunk:
                break
            buffer += chunk
            while (start := buffer.find(b"\xff\xd8")) >= 0 and (
                end := buffer.find(b"\xff\xd9", start)
            ) >= 0:
                msg = CompressedImage(format="jpeg", data=buffer[start : end + 2])
                msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(time.time_ns(), 10**9)
                publisher.publish(msg)
                buffer = buffer[end + 2 :]
    node.destroy_node()
    rclpy.shutdown()


class Peer:
    """One rclpy node in a spawned process."""

    def __init__(self, target: Callable[..., None], *args: Any, wait: bool = True) -> None:
        self.ready = SPAWN.Event()
        self.stop_event = SPAWN.Event()
        self.process = SPAWN.Process(target=target, args=(*args, self.ready, self.stop_event))
        self.process.start()
        if wait:
            self.wait_ready()

    def wait_ready(self) -> None:
        """Wait for its node to be up (the process killed and AssertionError after 60 s)."""
        if not self.ready.wait(60):
            self.kill()
            raise AssertionError("the ROS 2 peer did not start within 60 s")

    def stop(self) -> None:
        """Stop it and wait for it."""
        self.stop_event.set()
        self.process.join(10)
        if self.process.is_alive():
            self.kill()

    def kill(self) -> None:
        """SIGKILL: no goodbye on the ROS 2 side."""
        if self.process.pid is not None and self.process.is_alive():
            os.kill(self.process.pid, signal.SIGKILL)
        self.process.join(10)


def subscriber(topics: dict[str, str], out: Path) -> Peer:
    """A subscriber to ``{topic: joint_state|trajectory|array}`` writing to ``out``."""
    return Peer(_subscriber, topics, str(out))


def camera(
    topic: str,
    kind: str,
    encoding: str = "bgr8",
    fps: float = 30.0,
    *,
    stamped: bool = True,
    behind_s: float = 0.0,
    wait: bool = True,
) -> Peer:
    """A publisher of the performer video's frames (looped) as ``compressed`` (JPEG) or
    ``raw`` (``encoding``) images, stamped when sent (marked with :data:`STAMP_MARK`; zero
    without ``stamped``) by a clock ``behind_s`` behind this host's (a camera driver on another
    machine), best effort as cameras do. Without ``wait`` it is still starting when returned
    (:meth:`Peer.wait_ready`)."""
    behind_ns = round(behind_s * 1e9)
    return Peer(_publisher, topic, kind, encoding, fps, stamped, behind_ns, wait=wait)


def relay(url: str, topic: str) -> Peer:
    """A robot camera on ROS 2: each JPEG of the MJPEG stream at ``url`` (``facesynth
    simhead``'s camera) republished as it comes, a CompressedImage on ``topic`` stamped when
    sent, best effort as cameras do."""
    return Peer(_relay, url, topic)
