"""app.stages.sensor: a graph's sensor sends ``auto`` frames (raw to the stages of its process,
JPEG to the others) unless told otherwise, and JPEG when it runs in a process of its own,
where no stage takes its frames (a five-process chain's P gets what it always got)."""

from __future__ import annotations

from pathlib import Path

import cv2
import msgspec
import pytest

from facesynth.app.cli import main
from facesynth.app.data import sample_openface_csv, sample_video
from facesynth.app.graph import load_graph
from facesynth.app.recording.reader import Recording
from facesynth.app.wiring import build_node
from facesynth.services.sensor.service import SensorService

VIDEO = str(sample_video())
FRAMES = 5


@pytest.mark.parametrize(
    ("given", "in_run", "standalone"),
    [(None, "auto", "jpeg"), ("jpeg", "jpeg", "jpeg"), ("raw", "raw", "raw")],
)
def test_the_sensor_sends_auto_frames_in_a_chain_and_jpeg_on_its_own(
    given: str | None, in_run: str, standalone: str
) -> None:
    graph = load_graph(None, plugins=False)
    node = graph.nodes["sensor"]
    if given is not None:
        node = msgspec.structs.replace(node, encoding=given)
    encodings = []
    for alone in (False, True):
        parts = build_node("sensor", node, graph, standalone=alone)
        assert isinstance(parts.service, SensorService)
        encodings.append(parts.service.options.encoding)
        parts.service.source.close()
    assert encodings == [in_run, standalone]


def test_run_records_the_frames_as_jpeg_at_the_sensors_quality(tmp_path: Path) -> None:
    # The tracker takes the raw pixels in run's process (auto); the recording still holds each
    # frame as the JPEG a five-process sensor sends, byte for byte (a replayed point stream
    # stands in for the tracker: the frames are the video's all the same).
    session, out = tmp_path / "s.mcap", tmp_path / "c.jsonl"
    argv = ["run", "--video", VIDEO, "--openface-csv", str(sample_openface_csv()), "--fast"]
    argv += ["--max-frames", str(FRAMES), "--quality", "70", "--record", str(session)]
    assert main([*argv, "--out", str(out), "--listen", "tcp/127.0.0.1:0"]) == 0
    with Recording(session) as recording:
        frames = [m for _, m, _ in recording.messages(["facesynth/default/input"])]
    capture = cv2.VideoCapture(VIDEO)
    expected = []
    for _ in range(FRAMES):
        ok, image = capture.read()
        assert ok
        expected.append(cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 70])[1].tobytes())
    capture.release()
    assert [(f.seq, f.encoding) for f in frames] == [(seq, "jpeg") for seq in range(FRAMES)]
    assert [f.data for f in frames] == expected
