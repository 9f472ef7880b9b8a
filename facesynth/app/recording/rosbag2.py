"""A recording as a rosbag2 folder that ROS 2 tools play (``facesynth convert S.mcap --to
rosbag2 OUT/``).

The folder holds ``metadata.yaml`` and one MCAP file (profile ``ros2``, ``ros2msg`` schemas,
CDR), written with ``rosbags`` (pure Python, no ROS needed; it comes with the ``[record]``
extra). Topics, each message's bag time being when the recorder received it:

* ``/facesynth/joint_commands`` — ``sensor_msgs/msg/JointState``: every pose C sent to its
  driver (``…/servo_state``, its idle reports left out), or, in a recording without it, the
  translator's commands (of a multi-robot rig's recording, one robot's: ``--robot``); names
  and radians as the ``ros2`` driver publishes them (the profile's angle maps), the header
  stamp the frame's capture time;
* ``/facesynth/camera/image_raw/compressed`` — ``sensor_msgs/msg/CompressedImage``: the
  performer's frames, JPEG as recorded (raw pixels are encoded; ticks without pixels left out);
* ``/facesynth/features`` — ``std_msgs/msg/Float32MultiArray``: the named features, one
  dimension labelled with their names, comma-separated, in ``feature_names`` order (NaN where
  a frame has none).

The folder is written beside ``OUT`` under a temporary name and renamed at the end, so an
interrupted conversion leaves no half bag.
"""

from __future__ import annotations

import importlib
import math
import os
import shutil
import tempfile
from collections import Counter
from pathlib import Path
from typing import Any, Final

import numpy as np

from facesynth.app.recording.convert import export_keys
from facesynth.app.recording.reader import Recording
from facesynth.runtime.feature_names import NAMES
from facesynth.runtime.profiles import Profile, ProfileError, load_profile
from facesynth.schemas.messages import Features, Frame, ServoCommands

JOINTS: Final = "/facesynth/joint_commands"
IMAGES: Final = "/facesynth/camera/image_raw/compressed"
FEATURES: Final = "/facesynth/features"
#: The label of the features' one dimension starts with this, then the names.
FEATURES_LABEL: Final = ",".join(NAMES)


class Rosbag2Error(ValueError):
    """A recording that cannot become a rosbag2 folder; one line."""


def _rosbags() -> tuple[Any, Any, Any]:
    """``(Writer, StoragePlugin, typestore)``; one line naming the extra when missing."""
    try:
        rosbag2 = importlib.import_module("rosbags.rosbag2")
        typesys = importlib.import_module("rosbags.typesys")
    except ImportError:
        raise Rosbag2Error(
            "--to rosbag2 needs rosbags, which is not installed: pip install 'facesynth[record]'"
        ) from None
    return rosbag2.Writer, rosbag2.StoragePlugin, typesys.get_typestore(typesys.Stores.ROS2_JAZZY)


def commands_stage(recording: Recording) -> str | None:
    """Which stage's servo commands go in the bag (None: the recording has none)."""
    stages = recording.stages()
    for stage in ("servo_state", "servo_commands"):
        if stage in stages:
            return stage
    return None


def recorded_profile(recording: Recording, sources: list[str], given: str | None) -> Profile:
    """The profile whose angle maps turn the commands on ``sources`` into radians: ``given``,
    else the one the commands name (a name known here)."""
    name = given
    if name is None:
        first = next(recording.messages(sources[:1]), None)
        if first is None or not isinstance(first[1], ServoCommands):
            raise Rosbag2Error(f"{recording.path}: no servo commands to convert")
        name = first[1].profile
    try:
        return load_profile(name)
    except ProfileError as exc:
        raise Rosbag2Error(
            f"the commands' profile {name!r} cannot be loaded here ({exc}): give --profile"
        ) from None


class _Bag:
    """The typestore's message classes and the writer's connections."""

    def __init__(self, writer: Any, typestore: Any) -> None:
        self.writer = writer
        self.store = typestore
        self.types = typestore.types
        self.connections: dict[str, Any] = {}
        self.counts: Counter[str] = Counter()

    def write(self, topic: str, message: Any, time_ns: int) -> None:
        msgtype = message.__msgtype__
        if topic not in self.connections:
            self.connections[topic] = self.writer.add_connection(
                topic, msgtype, typestore=self.store
            )
        data = self.store.serialize_cdr(message, msgtype)
        self.writer.write(self.connections[topic], time_ns, data)
        self.counts[topic] += 1

    def header(self, stamp_ns: int) -> Any:
        sec, nanosec = divmod(max(0, stamp_ns), 1_000_000_000)
        stamp = self.types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec)
        return self.types["std_msgs/msg/Header"](stamp=stamp, frame_id="")


def _joint_state(bag: _Bag, profile: Profile, message: ServoCommands, log_ns: int) -> Any:
    names = [spec.name for spec in profile.servos if spec.name in message.positions]
    unknown = sorted(set(message.positions) - set(names))
    if unknown:
        raise Rosbag2Error(
            f"the commands name servos profile {profile.name} does not have ({', '.join(unknown)})"
            ": give --profile"
        )
    positions = [
        profile.servo(name).angle.radians(profile.servo(name).clamp(message.positions[name]))
        for name in names
    ]
    stamp = message.t_capture_ns if message.move == "command" else log_ns
    empty = np.array([], dtype=np.float64)
    return bag.types["sensor_msgs/msg/JointState"](
        header=bag.header(stamp),
        name=names,
        position=np.array(positions, dtype=np.float64),
        velocity=empty,
        effort=empty,
    )


def _image(bag: _Bag, frame: Frame) -> Any | None:
    if frame.encoding == "jpeg":
        data = frame.data
    elif frame.encoding == "none" or not frame.data:
        return None
    else:
        from facesynth.runtime.frames import FrameError, decode_frame
        from facesynth.runtime.opencv import import_cv2

        cv2 = import_cv2(Rosbag2Error)
        try:
            ok, encoded = cv2.imencode(".jpg", decode_frame(frame))
        except FrameError:
            return None
        if not ok:
            return None
        data = encoded.tobytes()
    return bag.types["sensor_msgs/msg/CompressedImage"](
        header=bag.header(frame.t_capture_ns),
        format="jpeg",
        data=np.frombuffer(data, dtype=np.uint8),
    )


def _features(bag: _Bag, features: Features) -> Any:
    values = [features.named.get(name, math.nan) for name in NAMES]
    dimension = bag.types["std_msgs/msg/MultiArrayDimension"](
        label=FEATURES_LABEL, size=len(NAMES), stride=len(NAMES)
    )
    layout = bag.types["std_msgs/msg/MultiArrayLayout"](dim=[dimension], data_offset=0)
    return bag.types["std_msgs/msg/Float32MultiArray"](
        layout=layout, data=np.array(values, dtype=np.float32)
    )


def export_rosbag2(
    recording: Recording,
    out: str | Path,
    *,
    profile: str | None = None,
    overwrite: bool = False,
    robot: str | None = None,
) -> dict[str, int]:
    """Write ``recording`` as the rosbag2 folder ``out``; the messages per topic. From a
    multi-robot rig's recording, ``robot``'s commands (:func:`~.convert.export_keys`)."""
    writer_class, storage, typestore = _rosbags()
    target = Path(out)
    if target.exists() and not (overwrite and target.is_dir()):
        what = "folder" if target.is_dir() else "file"
        raise Rosbag2Error(f"{target}: a {what} is already there (--overwrite replaces a folder)")
    if not target.parent.is_dir():
        raise Rosbag2Error(f"{target}: its folder {target.parent} does not exist")
    stage = commands_stage(recording)
    commands = export_keys(recording, stage, robot) if stage else []
    chosen = recorded_profile(recording, commands, profile) if stage else None
    keys = [*recording.stage_keys("input"), *recording.stage_keys("features"), *commands]
    if stage is None and not keys:
        raise Rosbag2Error(f"{recording.path}: no commands, frames or features to convert")
    work = Path(tempfile.mkdtemp(prefix=f".{target.name}.", dir=target.parent))
    bag_path = work / target.name
    try:
        with writer_class(bag_path, version=9, storage_plugin=storage.MCAP) as writer:
            bag = _Bag(writer, typestore)
            for _, message, log_ns in recording.messages(keys):
                if isinstance(message, ServoCommands) and chosen is not None:
                    if message.move != "report":
                        bag.write(JOINTS, _joint_state(bag, chosen, message, log_ns), log_ns)
                elif isinstance(message, Frame):
                    image = _image(bag, message)
                    if image is not None:
                        bag.write(IMAGES, image, log_ns)
                elif isinstance(message, Features):
                    bag.write(FEATURES, _features(bag, message), log_ns)
        if target.exists():
            shutil.rmtree(target)
        os.replace(bag_path, target)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return dict(bag.counts)
