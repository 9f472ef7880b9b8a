"""``facesynth convert S.mcap --to rosbag2 OUT/``: a rosbag2 folder that ROS 2 tools play, read
back with a reader other than the writer's (``mcap-ros2-support``; rosbags wrote it).

JointState carries every pose C sent (its idle reports left out) in the radians of the
profile's angle maps, stamped with the frame's capture time (C's own moves: when recorded);
CompressedImage the recorded JPEG byte for byte (raw pixels encoded, ticks left out);
Float32MultiArray the named features under a labelled dimension.
"""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from messages_sample import jpeg

from facesynth.app.cli import main
from facesynth.app.recording.layout import Layout
from facesynth.app.recording.reader import Recording
from facesynth.app.recording.rosbag2 import Rosbag2Error, export_rosbag2
from facesynth.app.recording.writer import SessionWriter
from facesynth.runtime import codec
from facesynth.runtime.feature_names import NAMES
from facesynth.runtime.profiles import load_profile
from facesynth.schemas.messages import Features, Frame, ServoCommands

T0 = 1_790_000_000_000_000_000
PROFILE = load_profile("paper16")


def pose(seq: int) -> dict[str, float]:
    return {spec.name: spec.neutral_us + (seq * 7 % 200) - 100 for spec in PROFILE.servos}


def write_session(path: Path, frames: int) -> None:
    layout = Layout()
    writer = SessionWriter(path, metadata={"rig": "default"}, fsync=False)
    index = 0

    def put(stage: str, message: object, log_ns: int) -> None:
        nonlocal index
        for entry in layout.entries(
            f"facesynth/default/{stage}", codec.encode(message), log_ns, index
        ):
            writer.write(entry)
        index += 1

    for seq in range(frames):
        t = T0 + seq * 33_333_333
        common = {"seq": seq, "t_capture_ns": t, "t_media_ns": seq * 33_333_333}
        put("input", Frame(**common, width=64, height=48, encoding="jpeg", data=jpeg()), t + 1)
        put(
            "input",
            Frame(**common, width=4, height=2, encoding="raw", data=bytes(range(24))),
            t + 2,
        )
        put("input", Frame(**common, width=640, height=480, encoding="none"), t + 3)
        named = {"jaw_open": 0.25 + seq / 100, "smile_left": -1.0 / 3.0}
        put("features", Features(**common, face=True, named=named), t + 4)
        state = ServoCommands(**common, face=True, profile="paper16", positions=pose(seq))
        put("servo_state", state, t + 5)
        report = ServoCommands(
            **common, face=True, profile="paper16", positions=pose(seq), move="report"
        )
        put("servo_state", report, t + 6)
    stop = ServoCommands(
        seq=frames - 1, t_capture_ns=T0, t_media_ns=0, face=False, profile="paper16",
        positions=PROFILE.neutral_positions(), move="stop",
    )  # fmt: skip
    put("servo_state", stop, T0 + frames * 33_333_333)
    writer.close()


def read_bag(folder: Path) -> dict[str, list[tuple[int, object]]]:
    """``{topic: [(log time, decoded message)]}`` read with mcap-ros2-support."""
    metadata = yaml.safe_load((folder / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert metadata["storage_identifier"] == "mcap" and metadata["version"] == 9
    (name,) = metadata["relative_file_paths"]
    out: dict[str, list[tuple[int, object]]] = {}
    with open(folder / name, "rb") as handle:
        reader = make_reader(handle, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
        assert summary is not None
        assert {s.encoding for s in summary.schemas.values()} == {"ros2msg"}
        assert {c.message_encoding for c in summary.channels.values()} == {"cdr"}
        for _, channel, message, decoded in reader.iter_decoded_messages():
            out.setdefault(channel.topic, []).append((message.log_time, decoded))
    return out


def test_a_session_reads_back_with_another_reader(tmp_path: Path) -> None:
    session, bag = tmp_path / "s.mcap", tmp_path / "bag"
    write_session(session, 5)
    with Recording(session) as recording:
        counts = export_rosbag2(recording, bag)
    topics = read_bag(bag)
    assert counts == {name: len(items) for name, items in topics.items()}
    joints = topics["/facesynth/joint_commands"]
    assert len(joints) == 6  # 5 commands and the stop; the reports left out
    names = [spec.name for spec in PROFILE.servos]
    for seq, (log_ns, message) in enumerate(joints[:5]):
        t = T0 + seq * 33_333_333
        assert log_ns == t + 5
        assert message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec == t
        assert list(message.name) == names
        wanted = [spec.angle.radians(pose(seq)[spec.name]) for spec in PROFILE.servos]
        assert list(message.position) == pytest.approx(wanted, abs=1e-12)
    stop_log, stop = joints[-1]
    assert stop.header.stamp.sec * 1_000_000_000 + stop.header.stamp.nanosec == stop_log
    assert list(stop.position) == pytest.approx([math.pi / 2] * 16)  # 1500 µs of 500-2500
    images = topics["/facesynth/camera/image_raw/compressed"]
    assert len(images) == 10  # the JPEG and the raw frame of each; ticks left out
    assert bytes(images[0][1].data) == jpeg() and images[0][1].format == "jpeg"
    raw = cv2.imdecode(np.frombuffer(bytes(images[1][1].data), np.uint8), cv2.IMREAD_COLOR)
    assert raw.shape == (2, 4, 3)
    features = topics["/facesynth/features"]
    assert len(features) == 5
    message = features[2][1]
    (dimension,) = message.layout.dim
    assert dimension.label.split(",") == list(NAMES) and dimension.size == len(NAMES)
    values = dict(zip(NAMES, message.data, strict=True))
    assert values["jaw_open"] == pytest.approx(0.27) and math.isnan(values["head_yaw"])


def test_the_command_line_writes_the_folder_and_refuses_what_is_there(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    session, bag = tmp_path / "s.mcap", tmp_path / "bag"
    write_session(session, 3)
    assert main(["convert", str(session), "--to", "rosbag2", str(bag)]) == 0
    assert '"/facesynth/joint_commands": 4' in capsys.readouterr().out
    before = sorted(p.name for p in bag.iterdir())
    assert main(["convert", str(session), "--to", "rosbag2", str(bag)]) == 2
    assert "a folder is already there (--overwrite replaces a folder)" in capsys.readouterr().err
    assert main(["convert", str(session), "--to", "rosbag2", str(bag), "--overwrite"]) == 0
    assert sorted(p.name for p in bag.iterdir()) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bag", "s.mcap"]  # no leftovers


def test_a_profile_that_does_not_fit_is_one_line(tmp_path: Path) -> None:
    session = tmp_path / "s.mcap"
    write_session(session, 2)
    with Recording(session) as recording, pytest.raises(Rosbag2Error) as caught:
        export_rosbag2(recording, tmp_path / "bag", profile="arkit52")
    assert "the commands name servos profile arkit52 does not have" in str(caught.value)
    assert not (tmp_path / "bag").exists()
    with Recording(session) as recording, pytest.raises(Rosbag2Error, match="give --profile"):
        export_rosbag2(recording, tmp_path / "bag", profile="no_such_robot")
