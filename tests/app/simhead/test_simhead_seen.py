"""The tracker SEES every primitive effect: the ``full`` model's features move the right way.

Each effect (each direction it has) is rendered on the bundled photo at activation ±1 and goes
through the real tracker (``full``, Face Landmarker v2) and F (``FeatureProcessor``, the photo
at rest as the neutral); its feature must move the expected way by at least :data:`MIN_SHARE`
of the feature's default range on that side (``facesynth.runtime.feature_names``).
"""

from __future__ import annotations

import msgspec
import numpy as np

from facesynth.app.simhead import EFFECTS, SimHead, head_names, load_head
from facesynth.app.simhead.renderer import default_renderer
from facesynth.runtime.feature_names import BY_NAME
from facesynth.runtime.frames import encode_frame
from facesynth.schemas.messages import Points
from facesynth.services.features.core import FeatureProcessor
from facesynth.services.points.backends.tracker import TrackerBackend, TrackerConfig

MIN_SHARE = 0.1
FRAME_NS = 33_333_333

#: (effect, direction) -> the features it must move, with the sign they must move by.
EXPECTED: dict[tuple[str, int], dict[str, int]] = {
    ("brow_right", 1): {"brow_raise_outer_right": 1, "brow_raise_inner_right": 1},
    ("brow_right", -1): {"brow_raise_outer_right": -1, "brow_lower_right": 1},
    ("brow_left", 1): {"brow_raise_outer_left": 1, "brow_raise_inner_left": 1},
    ("brow_left", -1): {"brow_raise_outer_left": -1, "brow_lower_left": 1},
    ("brow_inner", 1): {"brow_raise_inner_right": 1, "brow_raise_inner_left": 1},
    ("brow_inner", -1): {"brow_lower_right": 1, "brow_lower_left": 1},
    ("lids_right", 1): {"eye_open_right": 1},
    ("lids_right", -1): {"eye_open_right": -1},
    ("lids_left", 1): {"eye_open_left": 1},
    ("lids_left", -1): {"eye_open_left": -1},
    **{
        (g, s): {g: s}
        for g in ("gaze_right_x", "gaze_right_y", "gaze_left_x", "gaze_left_y")
        for s in (1, -1)
    },
    ("cheek_right", 1): {"lid_tighten_right": 1, "cheek_raise_right": 0},
    ("cheek_left", 1): {"lid_tighten_left": 1, "cheek_raise_left": 0},
    ("upper_lip_right", 1): {"lips_part": 1},
    ("upper_lip_left", 1): {"lips_part": 1},
    ("jaw", 1): {"jaw_open": 1, "lips_part": 1},
    ("jaw", -1): {"jaw_open": -1},
    ("lip_corner_right", 1): {"lip_corner_pull_right": 1},
    ("lip_corner_right", -1): {"lip_corner_depress_right": 1},
    ("lip_corner_left", 1): {"lip_corner_pull_left": 1},
    ("lip_corner_left", -1): {"lip_corner_depress_left": 1},
    ("lower_lip_right", 1): {"lips_part": 1},
    ("lower_lip_left", 1): {"lips_part": 1},
    ("lip_pucker", 1): {"lip_pucker": 1},
    ("lip_pucker", -1): {"lip_pucker": -1},
    ("blink_right", 1): {"eye_open_right": -1, "eyeBlinkRight": 1},
    ("blink_right", -1): {"eye_open_right": 1},
    ("blink_left", 1): {"eye_open_left": -1, "eyeBlinkLeft": 1},
    ("blink_left", -1): {"eye_open_left": 1},
    ("neck_yaw", 1): {"head_yaw": 1},
    ("neck_yaw", -1): {"head_yaw": -1},
    ("neck_pitch", 1): {"head_pitch": 1},
    ("neck_pitch", -1): {"head_pitch": -1},
}


def _track(backend: TrackerBackend, image: object, frames: int = 5) -> Points:
    points = None
    for i in range(frames):
        points = backend.process(
            encode_frame(image, seq=i, t_capture_ns=0, t_media_ns=0, encoding="raw")
        )
    assert points is not None and points.face
    return points


def _raw(neutral: Points, points: Points) -> dict[str, float]:
    # A robot held at neutral: its neutral is taken as it is (no brow re-basing, issue 20).
    processor = FeatureProcessor(neutral_seconds=0.1, neutral_held=True)
    for i in range(5):
        t = i * FRAME_NS
        processor.process(msgspec.structs.replace(neutral, seq=i, t_capture_ns=t, t_media_ns=t))
    t = 10 * FRAME_NS
    return processor.process(
        msgspec.structs.replace(points, seq=10, t_capture_ns=t, t_media_ns=t)
    ).raw


def test_every_effect_is_in_the_table() -> None:
    renderer = default_renderer()
    for effect in EFFECTS:
        for direction in (1, -1):
            moved = renderer.landmarks({effect: float(direction)}) - renderer.landmarks({})
            has_it = bool(abs(moved).max() > 0) or effect.startswith("gaze")
            assert ((effect, direction) in EXPECTED) == has_it, (effect, direction)


def test_the_tracker_sees_each_effect_move_its_feature_the_right_way() -> None:
    renderer = default_renderer()
    backend = TrackerBackend(TrackerConfig(model="full"))
    rest = renderer.render({})
    failures = []
    for (effect, direction), features in EXPECTED.items():
        backend.tracker.reset()
        neutral = _track(backend, rest)
        raw = _raw(neutral, _track(backend, renderer.render({effect: float(direction)})))
        for name, sign in features.items():
            value = raw[name]
            if sign == 0:  # must not move the wrong way either
                sign = 1
                need = -MIN_SHARE
            else:
                need = MIN_SHARE
            spec = BY_NAME[name]
            span = spec.default_max if sign > 0 else -spec.default_min
            share = sign * value / span
            if share < need:
                failures.append(f"{effect} {direction:+d}: {name} {value:+.4f} ({share:+.2f})")
    assert not failures, failures


def test_the_face_stays_trackable_in_random_poses() -> None:
    """Babbling sends random poses within paper16's limits: the tracker must keep the face."""
    backend = TrackerBackend(TrackerConfig(model="full", blendshapes=False))
    rng = np.random.default_rng(17)
    for name in head_names():
        head = SimHead(load_head(name))
        for pose in range(8):
            for channel in range(16):
                head.command(channel, float(rng.uniform(1000, 2000)))
            head.step((pose + 1) * 2_000_000_000)
            points = _track(backend, head.render(), frames=3)
            assert points.face and points.confidence > 0.5, (name, pose)
