"""The translator node's closed loop (``--robot-rig``, ``--loop-state``): checked when the node
is built, its state read from beside the learned profile, a bad state file one line."""

from __future__ import annotations

import time
from pathlib import Path

import msgspec
import numpy as np
import pytest

from facesynth.app.arguments import OptionError
from facesynth.app.data import sample_video
from facesynth.app.stages.closed_loop import robot_face
from facesynth.app.stages.robot_camera import RobotCamera
from facesynth.runtime.profiles import Profile, load_profile, save_learned_profile
from facesynth.runtime.profiles.learned import Learned, PolyRidge, Report, pack
from facesynth.schemas.messages import Features
from facesynth.services.sensor.sources.base import FrameSource, SourceError
from facesynth.services.sensor.sources.video import VideoConfig, VideoSource
from facesynth.services.translator.closed_loop import LoopState
from facesynth.services.translator.core import Translator
from facesynth.services.translator.loop_state import save_loop_state

INPUTS = ["brow_raise_inner_right", "jaw_open", "lip_corner_pull_right"]


def learned_profile() -> Profile:
    """head16_hardware's first four servos, three following one input each, with a
    self-model (the inverse model's inverse)."""
    hardware = load_profile("head16_hardware")
    names = [s.name for s in hardware.servos[:4]]
    identity = PolyRidge(
        degree=1, powers=pack(np.eye(3)), coef=pack(np.eye(3)), intercept=pack(np.zeros(3))
    )
    learned = Learned(
        inputs=INPUTS,
        reach_low=pack(np.full(3, -0.05)),
        reach_high=pack(np.full(3, 0.1)),
        input_mean=pack(np.zeros(3)),
        input_scale=pack(np.full(3, 0.1)),
        outputs=names[:3],
        dead=names[3:],
        inverse=identity,
        forward=identity,
        report=Report(model="poly_ridge", servo_error={}, candidates={}, samples=0, held_out=0),
    )
    return msgspec.structs.replace(
        hardware, name="robot", servos=hardware.servos[:4], learned=learned
    )


@pytest.fixture
def profile_file(tmp_path: Path) -> Path:
    return save_learned_profile(learned_profile(), tmp_path / "robot.learned")


def test_no_robot_rig_is_the_open_loop(profile_file: Path) -> None:
    translator = Translator(load_profile(str(profile_file)))
    assert robot_face(translator, None, str(profile_file), None) is None


def test_the_loop_resumes_what_was_kept_beside_the_profile(profile_file: Path) -> None:
    profile = load_profile(str(profile_file))
    assert profile.learned is not None
    kept = LoopState(weights=np.full((3, 4), 0.25), covariance=np.eye(4) * 0.5, updates=9)
    save_loop_state(kept, profile.name, profile.learned, profile_file.with_suffix(".loop"))
    translator = Translator(profile)
    face = robot_face(translator, "self", str(profile_file), None)
    assert face is not None
    assert face.key == "facesynth/self/features"
    assert face.state_path == profile_file.with_suffix(".loop")
    loop = translator.close_loop_once()
    assert loop.state.updates == 9 and np.array_equal(loop.state.weights, kept.weights)


def test_no_state_yet_starts_afresh(profile_file: Path, tmp_path: Path) -> None:
    translator = Translator(load_profile(str(profile_file)))
    face = robot_face(translator, "self", str(profile_file), str(tmp_path / "elsewhere.loop"))
    assert face is not None and face.state_path == tmp_path / "elsewhere.loop"
    assert translator.close_loop_once().state.updates == 0


def test_a_bad_state_file_is_one_line(profile_file: Path) -> None:
    profile_file.with_suffix(".loop").write_bytes(b"\x00not msgpack")
    translator = Translator(load_profile(str(profile_file)))
    with pytest.raises(OptionError, match=r"--robot-rig: loop state .*robot\.loop: not a") as info:
        robot_face(translator, "self", str(profile_file), None)
    assert "\n" not in str(info.value)


def test_robot_camera_tracks_the_robots_face_on_a_thread_of_its_own() -> None:
    def video() -> FrameSource:
        return VideoSource(VideoConfig(path=str(sample_video())))

    camera = RobotCamera(video)
    try:
        seen: list[Features] = []
        deadline = time.monotonic() + 120.0
        while time.monotonic() < deadline and not any(f.neutral_ready for f in seen):
            seen.extend(camera.faces())
            time.sleep(0.05)
    finally:
        camera.close()
    ready = [f for f in seen if f.face and f.neutral_ready]
    assert ready and ready[-1].raw  # F's features of the face, relative to its neutral
    stamps = [f.t_capture_ns for f in seen]
    assert stamps == sorted(stamps) and abs(stamps[-1] - time.time_ns()) < 120e9  # wall clock


def test_a_robot_camera_that_cannot_open_leaves_the_loop_open() -> None:
    def broken() -> FrameSource:
        raise SourceError("no such camera")

    camera = RobotCamera(broken)
    camera.close()
    assert camera.error == "the robot's camera failed: no such camera"
    assert camera.faces() == []


def test_robot_camera_closes_the_loop_in_this_process(profile_file: Path) -> None:
    translator = Translator(load_profile(str(profile_file)))
    face = robot_face(translator, None, str(profile_file), None, robot_camera="0")
    assert face is not None and face.key is None and face.local is not None
    assert face.state_path == profile_file.with_suffix(".loop")
