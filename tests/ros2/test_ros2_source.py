"""The ``ros2`` source against a real rclpy camera publisher in another process.

The publisher sends the performer video's frames at 30 fps, stamped (marked to the
nanosecond), best effort, as CompressedImage (JPEG) or Image (bgr8, rgb8, mono8): the chain
tracks her and the commands come out with a face, each stamped with its image's stamp. A
camera killed mid-run leaves the chain running (the face returns to neutral, the process stops
cleanly), and an encoding the source does not take stops it with one line.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from facesynth_processes import Processes
from ros2_peers import STAMP_MARK, Peer, camera

from facesynth.services.control.drivers.record import read_record

FRAMES = 90
#: Frames sent while C learns the camera's clock (1 s and 10 commands: none executed), and more.
PROBATION = 45


def graph(folder: Path, topic: str) -> Path:
    path = folder / "camera.toml"
    path.write_text(
        f"""rig = "ros2camera"
[nodes.sensor]
stage = "sensor"
source = {{ source = "ros2", topic = "{topic}" }}
[nodes.points]
stage = "points"
backend = {{ backend = "tracker" }}
[nodes.features]
stage = "features"
[nodes.translator]
stage = "translator"
profile = "paper16"
[nodes.control]
stage = "control"
profile = "paper16"
driver = {{ driver = "record", out = "{folder}/commands.jsonl" }}
"""
    )
    return path


def run_chain(peer: Peer, *args: str) -> subprocess.CompletedProcess[str]:
    """``facesynth run`` to its end, started while the camera ``peer`` starts (the source waits
    for images: the two start-ups overlap)."""
    chain = subprocess.Popen(
        [sys.executable, "-m", "facesynth", "run", *args, "--listen", "tcp/127.0.0.1:0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        peer.wait_ready()
        stdout, stderr = chain.communicate(timeout=300)
    finally:
        if chain.poll() is None:
            chain.kill()
            chain.communicate()
    return subprocess.CompletedProcess(chain.args, chain.returncode, stdout, stderr)


@pytest.mark.parametrize(
    ("topic", "kind", "encoding"),
    [
        ("/camera/image_raw/compressed", "compressed", ""),
        ("/camera/image_raw", "raw", "bgr8"),
        ("/camera/image_raw", "raw", "rgb8"),
        ("/camera/image_raw", "raw", "mono8"),  # a grey camera: her face in grey
    ],
    ids=["compressed-jpeg", "image-bgr8", "image-rgb8", "image-mono8"],
)
def test_the_chain_tracks_her_from_ros2_images(
    tmp_path: Path, topic: str, kind: str, encoding: str
) -> None:
    peer = camera(topic, kind, encoding, wait=False)
    try:
        done = run_chain(peer, str(graph(tmp_path, topic)), "--max-frames", str(FRAMES + PROBATION))
    finally:
        peer.stop()
    assert done.returncode == 0, done.stderr[-3000:]
    from_frames = [line for line in read_record(tmp_path / "commands.jsonl") if line.frame]
    assert len(from_frames) >= FRAMES * 0.9
    assert sum(line.face for line in from_frames) >= FRAMES * 0.8
    assert all(line.t_capture_ns % 1000 == STAMP_MARK for line in from_frames)  # the stamps
    assert all(0 < line.t_sent_ns - line.t_capture_ns < 1e9 for line in from_frames)
    moved = [line for line in from_frames if any(abs(v - 1500) > 5 for v in line.servos.values())]
    assert len(moved) > 10, "the face never moved"


def test_a_camera_whose_clock_runs_3_s_behind_still_moves_the_face(tmp_path: Path) -> None:
    # The camera driver's machine stamps 3 s behind this one. Its stamps name the camera's
    # clock ("ros2:<topic>"), so every stage and C learn its offset (C on probation: 1 s and
    # 10 commands) instead of taking each frame for 3 s old by their own clock: the face
    # moves. (Named as this host's, every frame was dropped as old and the face stayed still.)
    topic = "/camera/image_raw/compressed"
    peer = camera(topic, "compressed", behind_s=3.0, wait=False)
    try:
        done = run_chain(peer, str(graph(tmp_path, topic)), "--max-frames", str(FRAMES + PROBATION))
    finally:
        peer.stop()
    assert done.returncode == 0, done.stderr[-3000:]
    from_frames = [line for line in read_record(tmp_path / "commands.jsonl") if line.frame]
    assert len(from_frames) >= FRAMES * 0.9, done.stderr[-3000:]
    assert all(line.t_capture_ns % 1000 == STAMP_MARK for line in from_frames)  # the stamps
    assert all(2.9e9 < line.t_sent_ns - line.t_capture_ns < 4e9 for line in from_frames)
    moved = [line for line in from_frames if any(abs(v - 1500) > 5 for v in line.servos.values())]
    assert len(moved) > 10, "the face never moved"
    assert f"'ros2:{topic}', a clock not yet learnt" in done.stderr, done.stderr[-3000:]


def test_images_without_a_stamp_are_stamped_when_taken(tmp_path: Path) -> None:
    topic = "/camera/image_raw/compressed"
    peer = camera(topic, "compressed", stamped=False, wait=False)
    started = time.time_ns()
    try:
        done = run_chain(peer, str(graph(tmp_path, topic)), "--max-frames", "30")
    finally:
        peer.stop()
    assert done.returncode == 0, done.stderr[-3000:]
    assert "image stamps are " in done.stderr and "frames are stamped when taken" in done.stderr
    from_frames = [line for line in read_record(tmp_path / "commands.jsonl") if line.frame]
    assert len(from_frames) >= 25
    assert all(started < line.t_capture_ns < line.t_sent_ns for line in from_frames)


def test_a_killed_camera_never_stalls_the_chain(tmp_path: Path, procs: Processes) -> None:
    topic = "/camera/image_raw/compressed"
    peer = camera(topic, "compressed", wait=False)
    try:
        chain = procs.start(
            "run", str(graph(tmp_path, topic)), "--listen", "tcp/127.0.0.1:0", name="chain"
        )
        peer.wait_ready()
        record = tmp_path / "commands.jsonl"
        deadline = time.monotonic() + 60
        while not record.exists() or sum(line.face for line in read_record(record)) < 30:
            assert time.monotonic() < deadline and chain.poll() is None, procs.log("chain")
            time.sleep(0.1)
        peer.kill()
        killed = time.monotonic()
        while read_record(record)[-1].frame is not None:  # the watchdog: back to neutral
            assert time.monotonic() - killed < 5, "the face never returned to neutral"
            time.sleep(0.05)
        time.sleep(1.0)
        assert chain.poll() is None, procs.log("chain")
        chain.send_signal(signal.SIGTERM)
        assert chain.wait(15) == 130, procs.log("chain")[-3000:]  # an interrupted run
    finally:
        peer.kill()
    last = read_record(record)[-1]
    assert last.servos == pytest.approx({name: 1500.0 for name in last.servos}, abs=0.01)


def test_an_encoding_it_does_not_take_is_one_line(tmp_path: Path) -> None:
    topic = "/camera/image_raw"
    peer = camera(topic, "raw", "yuv422_yuy2", wait=False)
    try:
        done = run_chain(peer, str(graph(tmp_path, topic)), "--max-frames", "5")
    finally:
        peer.stop()
    assert done.returncode == 2, done.stderr[-3000:]
    last = done.stderr.strip().splitlines()[-1]
    assert last == (
        "facesynth run: error: an Image in encoding 'yuv422_yuy2': the ros2 source takes rgb8, "
        "bgr8 or mono8 (or a JPEG CompressedImage)"
    ), done.stderr[-3000:]
    assert "Traceback" not in done.stderr
