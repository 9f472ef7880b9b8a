"""facesynth.app.render: the side-by-side video, frame-aligned with its input."""

from __future__ import annotations

import io
import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from facesynth.app.cli import main
from facesynth.app.data import sample_video
from facesynth.app.graph import DEFAULT_GRAPH, load_graph
from facesynth.app.render import render_graph
from facesynth.app.render.video import Progress, RenderError
from facesynth.services.control.drivers.record import read_record

FRAMES = 36


@pytest.fixture(scope="module")
def short_video(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The sample's first frames as their own, complete video file (MJPG keeps them sharp)."""
    path = tmp_path_factory.mktemp("video") / "short.avi"
    capture = cv2.VideoCapture(str(sample_video()))
    fps = capture.get(cv2.CAP_PROP_FPS)
    writer = None
    for _ in range(FRAMES):
        ok, image = capture.read()
        assert ok
        if writer is None:
            size = (image.shape[1], image.shape[0])
            writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"MJPG"), fps, size)
        writer.write(image)
    assert writer is not None
    writer.release()
    capture.release()
    return path


def _video(path: Path) -> tuple[int, float, int, int, list[np.ndarray]]:
    capture = cv2.VideoCapture(str(path))
    frames = []
    while True:
        ok, image = capture.read()
        if not ok:
            break
        frames.append(image)
    fps = capture.get(cv2.CAP_PROP_FPS)
    capture.release()
    return len(frames), fps, frames[0].shape[1], frames[0].shape[0], frames


def test_one_output_frame_per_input_frame_at_the_same_rate(
    short_video: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "side.mp4"
    assert main(["render", "--video", str(short_video), "--out", str(out)]) == 0
    summary = json.loads(capsys.readouterr().out)
    count, fps, width, height, frames = _video(out)
    in_count, in_fps, in_width, in_height, inputs = _video(short_video)
    assert count == in_count == summary["frames"] == FRAMES
    assert fps == pytest.approx(in_fps, abs=0.01)
    assert height == in_height and width > in_width  # the face and paper16's bars beside it
    assert (summary["width"], summary["height"]) == (width, height)
    assert summary["faces"] == FRAMES
    # The left panel is the performer at its own size (landmark dots aside).
    difference = np.abs(frames[10][:, :in_width].astype(int) - inputs[10].astype(int))
    assert np.median(difference) < 6
    # The face panel is drawn: skin-coloured pixels in its middle.
    face = frames[10][:, in_width : in_width + height * 400 // 480]
    centre = face[height // 2, face.shape[1] // 2]
    assert abs(int(centre[2]) - 242) < 25 and abs(int(centre[0]) - 160) < 25  # BGR of the skin
    assert sorted(p.name for p in tmp_path.iterdir()) == ["side.mp4"]  # no temporary left


def test_same_size_keeps_the_inputs_frame_size(short_video: Path, tmp_path: Path) -> None:
    out = tmp_path / "small.avi"
    assert (
        main(
            [
                "render",
                "--video",
                str(short_video),
                "--out",
                str(out),
                "--same-size",
                "--bars",
                "none",
            ]
        )
        == 0
    )
    count, _, width, height, _ = _video(out)
    _, _, in_width, in_height, _ = _video(short_video)
    assert (count, width, height) == (FRAMES, in_width, in_height)


def test_the_face_moves_exactly_as_a_bus_run_commands_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The renderer's pure chain gives the face's controls that `facesynth run --fast` sends
    (the face with the default, blendshape-giving tracker: virtual_bs)."""
    commands = tmp_path / "virtual.jsonl"
    argv = [
        "run",
        "--fast",
        "--max-frames",
        "45",
        "--profile",
        "virtual_bs",
        "--out",
        str(commands),
        "--listen",
        "tcp/127.0.0.1:0",
    ]
    assert main(argv) == 0
    capsys.readouterr()
    sent = {line.frame: line.servos for line in read_record(commands) if line.frame is not None}
    assert len(sent) == 45

    graph = load_graph(str(DEFAULT_GRAPH), plugins=False)
    controls: list[dict[str, float]] = []
    from facesynth.app.render import video as video_module

    original = video_module.RenderChain.step

    def spy(self, image, seq, t_media_ns, fps):  # type: ignore[no-untyped-def]
        result = original(self, image, seq, t_media_ns, fps)
        controls.append(result.face)
        return result

    video_module.RenderChain.step = spy  # type: ignore[method-assign]
    try:
        render_graph(
            graph, {}, tmp_path / "v.mp4", max_frames=45, progress=Progress(45, io.StringIO())
        )
    finally:
        video_module.RenderChain.step = original  # type: ignore[method-assign]
    assert len(controls) == 45
    for frame in range(45):
        assert controls[frame] == pytest.approx(sent[frame], abs=0.002), frame
    assert any(c["jaw"] > 0 for c in controls) or any(c["brow_left"] != 500 for c in controls)


@pytest.mark.parametrize(("model", "face"), [("full", "virtual_bs"), ("fast", "virtual")])
def test_the_face_reads_its_brows_from_the_blendshapes_when_the_tracker_gives_them(
    model: str, face: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 20: the landmark brows read a laugh's squint as a frown; the blendshape brows do
    not (tests/features/test_brow_rest_video.py measures both on the sample's laugh)."""
    from facesynth.app.render import video as video_module

    faces: list[str] = []
    original = video_module.render_video

    def spy(source, chain, *args, **kwargs):  # type: ignore[no-untyped-def]
        faces.append(chain.face.profile.name)
        return original(source, chain, *args, **kwargs)

    monkeypatch.setattr("facesynth.app.render.render_video", spy)
    graph = load_graph(str(DEFAULT_GRAPH), plugins=False)
    graph.nodes["points"].backend["model"] = model  # type: ignore[attr-defined]
    render_graph(graph, {}, tmp_path / "v.mp4", max_frames=2, progress=Progress(2, io.StringIO()))
    assert faces == [face]


def test_a_failed_render_leaves_the_old_file_and_no_temporary(
    short_video: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "side.mp4"
    out.write_bytes(b"the previous video")
    from facesynth.app.render import video as video_module

    calls = 0
    original = video_module.compose

    def failing(*args, **kwargs):  # type: ignore[no-untyped-def]
        nonlocal calls
        calls += 1
        if calls == 10:
            raise KeyboardInterrupt  # as a Ctrl-C halfway through
        return original(*args, **kwargs)

    monkeypatch.setattr(video_module, "compose", failing)
    assert main(["render", "--video", str(short_video), "--out", str(out)]) == 130
    assert out.read_bytes() == b"the previous video"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["side.mp4"]


def test_a_corrupt_video_is_one_error_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.mp4"
    bad.write_bytes(b"\x00\x00\x00\x18ftypmp42" + b"\x00" * 500)
    assert main(["render", "--video", str(bad), "--out", str(tmp_path / "o.mp4")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("facesynth render: error: ") and "Traceback" not in err
    assert not (tmp_path / "o.mp4").exists()


def test_run_renders_its_input_when_asked(
    short_video: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run.mp4"
    argv = [
        "run",
        "--fast",
        "--video",
        str(short_video),
        "--out",
        str(tmp_path / "c.jsonl"),
        "--render",
        str(out),
        "--listen",
        "tcp/127.0.0.1:0",
    ]
    assert main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["frames"] == FRAMES and summary["render"]["frames"] == FRAMES
    assert _video(out)[0] == FRAMES


def test_the_progress_bar_shows_on_a_terminal_only() -> None:
    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    terminal, pipe = Terminal(), io.StringIO()
    for stream in (terminal, pipe):
        progress = Progress(40, stream, width=10)
        for done in range(1, 41):
            progress.update(done)
        progress.update(40, final=True)
    assert pipe.getvalue() == ""
    text = terminal.getvalue()
    assert text.startswith("\rrender [") and text.endswith(
        "40/40 frames" + text.split("frames")[-1]
    )
    assert "[##########] 40/40 frames" in text and text.endswith(" fps\n")
    assert Progress(40, pipe, width=10).line(10, 0.0).startswith("render [##........] 10/40")
    assert Progress(None, pipe).line(5, 0.0).startswith("render 5 frames")


def test_render_errors_are_value_errors() -> None:
    assert issubclass(RenderError, ValueError)


def test_the_robot_panel_shows_the_simulated_head(
    short_video: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """performer | the simulated head's camera | the bars of what C sent it."""
    out = tmp_path / "robot.avi"
    argv = ["render", "--video", str(short_video), "--out", str(out)]
    assert main([*argv, "--robot-head", "simhead16", "--profile", "head16"]) == 0
    summary = json.loads(capsys.readouterr().out)
    count, _, width, height, frames = _video(out)
    _, _, in_width, in_height, inputs = _video(short_video)
    assert count == summary["frames"] == FRAMES and height == in_height
    side = in_height // 2 * 2
    assert width == in_width + side + round(in_height * 0.8) // 2 * 2  # robot square, bars
    robot = [frame[30:, in_width : in_width + side].astype(int) for frame in frames]
    # the head's photo fills the square panel below its title: a face, not the background
    from facesynth.app.render.draw import BACKGROUND

    assert np.abs(robot[0] - np.array(BACKGROUND)).mean() > 40
    # it moves: the head follows the performer's frown over these frames
    assert np.abs(robot[-1] - robot[0]).mean() > 1.0
    # the left panel is still the performer
    difference = np.abs(frames[10][:, :in_width].astype(int) - inputs[10].astype(int))
    assert np.median(difference) < 6
    # without bars: performer | robot only
    assert main([*argv, "--robot-head", "simhead16", "--bars", "none", "--max-frames", "3"]) == 0
    capsys.readouterr()
    assert _video(out)[2] == in_width + side


def closed_loop_profile(folder: Path) -> Path:
    """A learned profile for simhead16 written here: its first three servos follow three
    features, the others held (and a self-model says each moves its feature alone: the head's
    real coupling and curves differ, so its loop, closed, corrects the commands)."""
    import msgspec

    from facesynth.runtime.profiles import Learned, load_profile, save_learned_profile
    from facesynth.runtime.profiles.learned import PolyRidge, Report, pack

    hardware = load_profile("head16_hardware")
    inputs = ["brow_raise_inner_right", "jaw_open", "lip_corner_pull_right"]
    outputs = [spec.name for spec in hardware.servos[:3]]
    identity = PolyRidge(
        degree=1, powers=pack(np.eye(3)), coef=pack(np.eye(3)), intercept=pack(np.zeros(3))
    )
    learned = Learned(
        inputs=inputs,
        reach_low=pack(np.full(3, -0.05)),
        reach_high=pack(np.full(3, 0.1)),
        input_mean=pack(np.zeros(3)),
        input_scale=pack(np.full(3, 0.05)),
        outputs=outputs,
        dead=[spec.name for spec in hardware.servos[3:]],  # held at neutral
        inverse=identity,
        forward=identity,
        report=Report(model="poly_ridge", servo_error={}, candidates={}, samples=0, held_out=0),
    )
    profile = msgspec.structs.replace(hardware, name="loop", learned=learned)
    return save_learned_profile(profile, folder / "loop.learned")


def test_the_closed_loop_beside_the_open_loop(
    short_video: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """performer | the head with T's loop closed | the same head in open loop, no bars: two
    heads, sent the same commands until the closed loop has seen its head's face, and then
    corrected ones."""
    from facesynth.app.simhead import SimHead

    sent: dict[int, list[tuple[int, float]]] = {}
    original = SimHead.command

    def command(self: SimHead, channel: int, pulse_us: float) -> None:
        sent.setdefault(id(self), []).append((channel, pulse_us))
        original(self, channel, pulse_us)

    monkeypatch.setattr(SimHead, "command", command)
    profile = closed_loop_profile(tmp_path)
    out = tmp_path / "loop.avi"
    argv = ["render", "--video", str(short_video), "--out", str(out), "--robot-head", "simhead16"]
    assert main([*argv, "--profile", str(profile), "--closed-loop"]) == 0
    assert json.loads(capsys.readouterr().out)["frames"] == FRAMES
    count, _, width, height, _ = _video(out)
    _, _, in_width, in_height, _ = _video(short_video)
    assert count == FRAMES and height == in_height
    assert width == in_width + 2 * (in_height // 2 * 2)  # two square heads, no bars
    closed, opened = (np.array(pulses) for pulses in sent.values())  # made in this order
    assert closed.shape == opened.shape
    channels = closed[:, 0] < 3  # the three servos the profile drives
    apart = np.abs(closed[:, 1] - opened[:, 1])[channels]
    assert apart[:3].max() == 0.0  # both start at the profile's neutral
    assert apart.max() > 1.0  # then the closed loop corrects its commands (µs)


@pytest.fixture
def closes(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """The videos a render closes, by name, as it closes them."""
    from facesynth.services.sensor.sources.video import VideoSource

    closed: list[str] = []
    original = VideoSource.close

    def close(self: VideoSource) -> None:
        closed.append(self.info.name)
        original(self)

    monkeypatch.setattr(VideoSource, "close", close)
    return closed


def test_a_render_that_cannot_build_its_bars_closes_its_video(
    short_video: Path, tmp_path: Path, closes: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["render", "--video", str(short_video), "--out", str(tmp_path / "o.avi")]
    assert main([*argv, "--bars", "no_such_profile"]) == 2
    assert "no_such_profile" in capsys.readouterr().err
    assert closes == [str(short_video)]


def test_a_second_head_that_cannot_open_closes_what_was_opened(
    short_video: Path, tmp_path: Path, closes: list[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """``render --closed-loop`` opens two heads: the second failing leaves nothing open."""
    import facesynth.app.simhead as simhead

    heads: list[object] = []
    real = simhead.SimHead

    def one_head_only(*args: object) -> object:
        if heads:
            raise OSError("the second head is not there")
        heads.append(real(*args))
        return heads[-1]

    monkeypatch.setattr(simhead, "SimHead", one_head_only)
    argv = ["render", "--video", str(short_video), "--out", str(tmp_path / "o.avi")]
    argv += ["--robot-head", "simhead16", "--profile", str(closed_loop_profile(tmp_path))]
    with pytest.raises(OSError, match="the second head is not there"):
        main([*argv, "--closed-loop"])
    assert len(heads) == 1
    assert closes == [str(short_video)]
    assert not (tmp_path / "o.avi").exists()
