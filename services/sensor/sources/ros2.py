"""A ROS 2 camera topic as the sensor's frames: the robot's own camera feeds the chain.

``--ros2-image-topic TOPIC`` subscribes to ``sensor_msgs/msg/CompressedImage`` (a topic ending
in ``/compressed``, or ``--ros2-image-type compressed``) or ``sensor_msgs/msg/Image``
(``raw``). JPEGs pass through as the MJPEG camera's do; Image in rgb8, bgr8 or mono8 becomes
pixels (:mod:`.ros2_images`); another encoding or format stops the source with one line
naming those it takes. Each image's header stamp is its capture time, read on the camera
driver's clock, which may be another machine's: the frames name it ``ros2:<topic>`` as their
capture host (:func:`.ros2_images.capture_time`), so the stages downstream and the control
interface learn its offset as another host's (C on probation, 1 s) rather than age it as their
own (a camera 0.3 s behind would keep the face still). A stamp that is no wall clock at all
(zero, simulated time, more than 5 s away: :func:`.ros2_images.trusted_stamp`) is replaced by
the time the image was taken here, said once in the log: that one is this host's clock.

It keeps the latest image only, with the QoS camera drivers publish with (best effort, keep
last 1): while the chain handles one frame, newer images replace each other, and the next frame
is the newest. It waits for images as long as it runs (saying so every ``QUIET_LOG_S``), in the
sensor's worker thread, so nothing else waits with it.

rclpy comes with the ``[ros2]`` extra and is imported only when this source is built.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Iterator
from typing import Annotated, Any, Final, Literal

import msgspec

from facesynth.runtime.ros2 import Ros2Node, import_ros2, qos_profile, stamp_ns
from facesynth.services.sensor.sources.base import FrameSource, Image, SourceError, SourceInfo
from facesynth.services.sensor.sources.registry import SOURCES
from facesynth.services.sensor.sources.ros2_images import (
    BadImage,
    capture_time,
    compressed_image,
    raw_image,
)

log = logging.getLogger(__name__)

#: A source without images says so this often (seconds).
QUIET_LOG_S: Final = 10.0
#: How long one wait for an image lasts before the source looks whether it was closed.
SPIN_S: Final = 0.1
#: A dropped message is logged the first time and then every this many.
LOG_EVERY: Final = 100


class Ros2SourceConfig(
    msgspec.Struct, tag="ros2", tag_field="source", kw_only=True, forbid_unknown_fields=True
):
    """Images from a ROS 2 topic: CompressedImage (JPEG) or Image (rgb8, bgr8, mono8)."""

    topic: Annotated[
        str,
        msgspec.Meta(
            description="ROS 2 image topic (default /camera/image_raw)",
            extra={"flag": "--ros2-image-topic", "selects": True},
        ),
    ] = "/camera/image_raw"
    image_type: Annotated[
        Literal["auto", "compressed", "raw"],
        msgspec.Meta(
            description="compressed (sensor_msgs/CompressedImage), raw (sensor_msgs/Image) or "
            "auto (default: compressed when the topic ends in /compressed)",
            extra={"flag": "--ros2-image-type"},
        ),
    ] = "auto"
    fps: Annotated[
        float, msgspec.Meta(gt=0, le=1000, description="the camera's nominal rate (default 30)")
    ] = 30.0
    node: Annotated[
        str,
        msgspec.Meta(
            description="ROS 2 node name (default facesynth_camera)",
            extra={"flag": "--ros2-camera-node"},
        ),
    ] = "facesynth_camera"


def is_compressed(config: Ros2SourceConfig) -> bool:
    """Whether the topic carries CompressedImage."""
    if config.image_type == "auto":
        return config.topic.rstrip("/").endswith("/compressed")
    return config.image_type == "compressed"


@SOURCES.register(Ros2SourceConfig)
class Ros2Source(FrameSource):
    """The latest image of a ROS 2 topic, stamped with its header's time."""

    needs_extra = "ros2"
    waits = True

    def __init__(self, config: Ros2SourceConfig) -> None:
        self.compressed = is_compressed(config)
        _, msgs = import_ros2(SourceError, "ros2 source", "sensor_msgs.msg")
        from rclpy.exceptions import InvalidNodeNameException, InvalidTopicNameException
        from rclpy.validate_node_name import validate_node_name
        from rclpy.validate_topic_name import validate_topic_name

        try:
            validate_topic_name(config.topic)
            validate_node_name(config.node)
        except (InvalidTopicNameException, InvalidNodeNameException) as exc:
            reason = " ".join(str(exc).splitlines()[0].split()).rstrip(":")
            raise SourceError(f"ros2 source: {reason}") from None
        self.topic = config.topic
        kind = "CompressedImage" if self.compressed else "Image"
        self.info = SourceInfo(f"ros2:{config.topic} ({kind})", config.fps, None, live=True)
        self.dropped = 0
        self._latest: Any = None
        self._captured: int | None = None
        self._clock = ""
        self._untrusted = False
        self._closing = threading.Event()
        self._busy = threading.Lock()
        self._ros = Ros2Node(config.node, SourceError)
        try:
            from rclpy.executors import SingleThreadedExecutor

            self._subscription = self._ros.node.create_subscription(
                getattr(msgs, kind), config.topic, self._take, qos_profile("best_effort", 1)
            )
            #: The topic as resolved in the node's namespace: its stamps' clock is named so.
            self.resolved_topic: str = self._subscription.topic_name
            self._executor = SingleThreadedExecutor(context=self._ros.context)
            self._executor.add_node(self._ros.node)
        except Exception:
            self._ros.close()
            raise

    def _take(self, message: Any) -> None:
        self._latest = message

    def frames(self) -> Iterator[tuple[Image, int]]:
        first: int | None = None
        while True:
            message = self._next_message()
            if message is None:
                return
            try:
                image = self._image(message)
            except BadImage as exc:
                self._drop(exc)
                continue
            self._captured = self._capture_time(stamp_ns(message.header.stamp))
            first = self._captured if first is None else first
            yield image, max(0, self._captured - first)

    def _capture_time(self, stamp: int) -> int:
        """The stamp, on the camera's clock, unless it is no wall clock: then the time the image
        was taken here, on this host's (said once; :func:`capture_time`)."""
        now = time.time_ns()
        captured, self._clock = capture_time(stamp, now, self.resolved_topic)
        if not self._clock and not self._untrusted:
            self._untrusted = True
            log.warning(
                "%s: image stamps are %.1f s from this host's clock (not set, simulated time, "
                "or another clock): frames are stamped when taken here",
                self.info.name,
                (now - stamp) / 1e9,
            )
        return captured

    def _next_message(self) -> Any:
        """The newest message once one came (None once the source is closed)."""
        quiet_since = time.monotonic()
        with self._busy:
            while not self._closing.is_set():
                self._executor.spin_once(timeout_sec=SPIN_S)
                message, self._latest = self._latest, None
                if message is not None:
                    return message
                if time.monotonic() - quiet_since >= QUIET_LOG_S:
                    log.warning("%s: no image for %.0f s", self.info.name, QUIET_LOG_S)
                    quiet_since = time.monotonic()
        return None

    def _image(self, message: Any) -> Image:
        if self.compressed:
            return compressed_image(message.format, bytes(message.data))
        return raw_image(
            message.encoding, message.width, message.height, message.step, bytes(message.data)
        )

    def _drop(self, problem: BadImage) -> None:
        self.dropped += 1
        if self.dropped % LOG_EVERY == 1:
            log.warning("%s: dropped %s (%d so far)", self.info.name, problem, self.dropped)

    def capture_time_ns(self) -> int | None:
        return self._captured

    def capture_clock(self) -> str:
        return self._clock

    def close(self) -> None:
        """Stop waiting for images, then destroy the node (after a wait under way ends)."""
        self._closing.set()
        if self._busy.acquire(timeout=5 * SPIN_S + 1):
            try:
                self._executor.shutdown(timeout_sec=1)
                self._ros.close()
            finally:
                self._busy.release()
