"""Fit on the simulated head: babble it in-process (command a random pose, let it settle,
render, track with the ``full`` model, F with the head at rest as the neutral) and fit."""

from __future__ import annotations

import msgspec
import numpy as np
import pytest

from facesynth.app.learn.dataset import BabbleSet
from facesynth.app.learn.fit import FitOptions, fit_learned_profile
from facesynth.app.simhead import SimHead, load_head
from facesynth.runtime.feature_names import NAMES
from facesynth.runtime.frames import encode_frame
from facesynth.runtime.profiles import Profile, load_profile
from facesynth.schemas.messages import Points
from facesynth.services.features.core import FeatureProcessor
from facesynth.services.points.backends.tracker import TrackerBackend, TrackerConfig

SETTLE_NS = 1_500_000_000  # the head's slew and lag are over well within this
FRAME_NS = 33_333_333


def babble_simhead(
    profile: Profile,
    poses: int,
    *,
    head: str = "simhead16",
    seed: int = 0,
    neutral_every: int = 20,
    frames: int = 2,
) -> BabbleSet:
    """``poses`` random poses (uniform in normalized units) of a simulated head, each tracked
    for ``frames`` frames (the tracker follows its last face: more frames, less hysteresis)."""
    sim = SimHead(load_head(head))
    backend = TrackerBackend(TrackerConfig(model="full"))
    processor = FeatureProcessor(neutral_seconds=0.1)
    specs = profile.servos
    neutral = np.array([s.neutral_us for s in specs])
    up = np.array([s.max_us - s.neutral_us for s in specs])
    down = np.array([s.neutral_us - s.min_us for s in specs])
    rng = np.random.default_rng(seed)
    seq = 0

    def look(pulses: np.ndarray, frames: int) -> dict[str, float]:
        nonlocal seq
        for spec, pulse in zip(specs, pulses, strict=True):
            sim.command(spec.channel, float(pulse))
        sim.step(sim.t_ns + SETTLE_NS)
        image = sim.render()
        features = None
        for _ in range(frames):
            sim.step(sim.t_ns + FRAME_NS)
            frame = encode_frame(
                image, seq=seq, t_capture_ns=sim.t_ns, t_media_ns=sim.t_ns, encoding="raw"
            )
            points: Points = backend.process(frame)
            features = processor.process(points)
            seq += 1
        assert features is not None
        return features.raw if features.face and features.neutral_ready else {}

    look(neutral, 6)  # F's neutral: the head at rest
    commands, faces, kinds = [], [], []
    for index in range(poses):
        if index % neutral_every == 0:
            u, kind = np.zeros(len(specs)), "neutral"
        else:
            u, kind = rng.uniform(-1.0, 1.0, len(specs)), "random"
        pulses = neutral + np.where(u >= 0, u * up, u * down)
        raw = look(pulses, frames)
        commands.append(pulses)
        faces.append([raw.get(name, np.nan) for name in NAMES])
        kinds.append(kind)
    return BabbleSet(
        servos=tuple(s.name for s in specs),
        commands=np.array(commands),
        inputs=NAMES,
        faces=np.array(faces, dtype=np.float64),
        kinds=tuple(kinds),
    )


@pytest.mark.slow
def test_fit_on_a_babbled_simulated_head() -> None:
    profile = load_profile("head16_hardware")
    babble = babble_simhead(profile, 160)
    learned = fit_learned_profile(
        babble, profile, FitOptions(candidates=("poly_ridge", "knn"))
    ).learned
    assert learned is not None
    report = learned.report
    # Every servo of simhead16 moves the face; 160 poses are few: a loose bound here (the
    # report of the branch gives the figures of a full babbling).
    assert len(learned.outputs) >= 12
    assert np.mean(list(report.servo_error.values())) < 0.2
    assert not any(name.startswith("head_") for name in learned.inputs)
    assert msgspec.structs.replace(profile, learned=learned).learned is learned
