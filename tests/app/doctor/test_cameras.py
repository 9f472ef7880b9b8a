"""facesynth.app.doctor.cameras: video devices found, the graph's camera opened as the sensor
opens it, and one line each (the simulated head's MJPEG camera: test_serial_ports.py)."""

from __future__ import annotations

import socket
import time
from pathlib import Path

import pytest

from facesynth.app.doctor.cameras import (
    CameraResult,
    camera_findings,
    cameras_to_open,
    open_camera,
    video_devices,
)


def test_video_devices_by_index(tmp_path: Path) -> None:
    for name in ("video10", "video2", "video-meta", "vide0", "video"):
        (tmp_path / name).touch()
    assert video_devices(tmp_path) == [(2, tmp_path / "video2"), (10, tmp_path / "video10")]
    assert video_devices(tmp_path / "missing") == []


def test_the_graphs_camera_first_then_each_device_once() -> None:
    devices = [(0, Path("/dev/video0")), (2, Path("/dev/video2"))]
    needed = [("sensor", "/dev/video2"), ("cam", "http://h:8090/camera.mjpg")]
    assert cameras_to_open(devices, needed) == [2, "http://h:8090/camera.mjpg", 0]
    assert cameras_to_open([], [("sensor", 0)]) == [0]


def test_a_url_nothing_serves_is_said_not_hung_on(unused_port: int) -> None:
    started = time.monotonic()
    result = open_camera(f"http://127.0.0.1:{unused_port}/camera.mjpg")
    assert result.size is None and result.problem is not None
    assert "cannot open the camera stream" in result.problem
    assert time.monotonic() - started < 10


def test_findings_for_no_camera_a_camera_and_no_opencv() -> None:
    devices = [(0, Path("/dev/video0")), (1, Path("/dev/video1"))]
    results = [CameraResult(0, size=(640, 480)), CameraResult(1, problem="cannot open camera 1")]
    lines = [f.line() for f in camera_findings(devices, results, [("sensor", "1")], opencv=True)]
    assert lines == [
        "ok   camera   index 0 (/dev/video0): opens, 640x480",
        "fix  camera   index 1 (/dev/video1) (sensor node sensor): cannot open camera 1: check it "
        "is connected and no other program uses it, or choose another with --camera",
    ]
    none = camera_findings(
        [], [CameraResult(0, problem="cannot open camera 0")], [("s", 0)], opencv=True
    )
    assert [f.status.value for f in none] == ["info", "fix"]
    assert none[1].fix.startswith("plug a camera in, or give a stream URL with --camera")
    blind = camera_findings(devices, [], [("s", 0)], opencv=False)
    assert [f.line() for f in blind][:1] == [
        "fix  camera   OpenCV: not installed: cameras cannot be opened: pip install "
        "'facesynth[tracker]'"
    ]
    assert [f.status.value for f in blind[1:]] == ["info", "info"]
    assert camera_findings([], [], [], opencv=False)[0].status.value == "note"


@pytest.fixture
def unused_port() -> int:
    """A loopback port nothing listens on."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])
