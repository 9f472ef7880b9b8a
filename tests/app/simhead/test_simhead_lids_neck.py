"""The heads with lids and with a neck, seen by our tracker: closed lids read as blinks, the
neck's yaw and pitch as F's head_yaw and head_pitch, in sign and magnitude.

Each head is commanded through its channels as a driver would (``SimHead.command``), left to
settle, rendered and tracked (``full`` model, blendshapes on) against the head at rest as F's
neutral (held, as a robot's neutral is).
"""

from __future__ import annotations

import msgspec
import numpy as np
import pytest

from facesynth.app.simhead import SimHead, load_head, response
from facesynth.app.simhead.neck import NECK_DEGREES
from facesynth.runtime.frames import encode_frame
from facesynth.schemas.messages import Points
from facesynth.services.features.core import FeatureProcessor
from facesynth.services.points.backends.tracker import TrackerBackend, TrackerConfig

SETTLE_NS = 2_000_000_000
FRAME_NS = 33_333_333


@pytest.fixture(scope="module")
def backend() -> TrackerBackend:
    return TrackerBackend(TrackerConfig(model="full"))


def _track(backend: TrackerBackend, image: np.ndarray) -> Points:
    points = None
    for i in range(5):
        frame = encode_frame(image, seq=i, t_capture_ns=0, t_media_ns=0, encoding="raw")
        points = backend.process(frame)
    assert points is not None and points.face
    return points


def _seen(backend: TrackerBackend, head: str, pulses: dict[int, float]) -> dict[str, float]:
    """F's raw features of ``head`` with ``pulses`` on its channels, against it at rest."""
    sim = SimHead(load_head(head))
    backend.tracker.reset()
    neutral = _track(backend, sim.render())
    for channel, pulse in pulses.items():
        sim.command(channel, pulse)
    sim.step(SETTLE_NS)
    assert not sim.moving()
    points = _track(backend, sim.render())
    processor = FeatureProcessor(neutral_seconds=0.1, neutral_held=True)
    for i in range(5):
        t = i * FRAME_NS
        processor.process(msgspec.structs.replace(neutral, seq=i, t_capture_ns=t, t_media_ns=t))
    t = 10 * FRAME_NS
    return processor.process(
        msgspec.structs.replace(points, seq=10, t_capture_ns=t, t_media_ns=t)
    ).raw


def test_closed_lids_read_as_blinks(backend: TrackerBackend) -> None:
    shut = _seen(backend, "simhead18_lids", {16: 2000.0, 17: 2000.0})
    for side in ("Right", "Left"):
        assert shut[f"eyeBlink{side}"] > 0.3, shut[f"eyeBlink{side}"]
    assert shut["eye_open_right"] < -0.15 and shut["eye_open_left"] < -0.15
    one = _seen(backend, "simhead18_lids", {16: 2000.0})  # the right lid alone
    assert one["eyeBlinkRight"] > 0.2 and one["eyeBlinkLeft"] < 0.1
    assert one["eye_open_right"] < -0.1 < one["eye_open_left"]
    half = _seen(backend, "simhead18_lids", {16: 1750.0, 17: 1750.0})
    assert 0.05 < half["eyeBlinkRight"] < shut["eyeBlinkRight"]
    wide = _seen(backend, "simhead18_lids", {16: 1000.0, 17: 1000.0})
    assert wide["eyeBlinkRight"] < 0.05 and wide["eyeBlinkLeft"] < 0.05
    assert wide["eye_open_right"] > 0.02 and wide["eye_open_left"] > 0.02


def _commanded_degrees(head: str, channel: int, pulse: float, effect: str) -> float:
    actuator = load_head(head).by_channel()[channel]
    amount = actuator.effects[effect] * response(actuator, pulse)
    return float(np.clip(amount, -1.5, 1.5)) * NECK_DEGREES[effect]


@pytest.mark.parametrize(
    ("channel", "effect", "feature"),
    [(16, "neck_yaw", "head_yaw"), (17, "neck_pitch", "head_pitch")],
)
def test_the_neck_turns_the_head_the_tracker_sees(
    backend: TrackerBackend, channel: int, effect: str, feature: str
) -> None:
    """head_yaw / head_pitch follow the neck's commanded angle: same sign, in order, the
    other axis hardly moving; yaw within half to one and a half times its size. The tracker
    reads about half of the pitch the warp renders (measured: 7-11 degrees for 15-20), so
    pitch only within 0.3 to 1.5 times."""
    low = 0.5 if feature == "head_yaw" else 0.3
    other = "head_pitch" if feature == "head_yaw" else "head_yaw"
    seen, wanted = [], []
    for pulse in (1050.0, 1250.0, 1750.0, 1950.0):
        raw = _seen(backend, "simhead18_neck", {channel: pulse})
        degrees = _commanded_degrees("simhead18_neck", channel, pulse, effect)
        assert abs(degrees) > 4.0
        assert np.sign(raw[feature]) == np.sign(degrees), (pulse, raw[feature], degrees)
        assert low < raw[feature] / degrees < 1.5, (pulse, raw[feature], degrees)
        assert abs(raw[other]) < 0.3 * abs(raw[feature]) + 1.0, (pulse, raw[other])
        seen.append(raw[feature])
        wanted.append(degrees)
    order = np.argsort(wanted)
    assert np.all(np.diff(np.asarray(seen)[order]) > 0), (wanted, seen)
