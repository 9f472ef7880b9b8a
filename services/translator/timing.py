"""T's cost per frame with a profile: milliseconds per :meth:`Translator.step`, measured.

For ``python -m facesynth.app.learn.fit PROFILE`` and the benchmarks: tracked frames with every
input moving (a learned profile's inputs within twice the robot's reach; a written profile's
named features within ±1 and its point groups by up to 0.1 IOD), smoothing, motion limits and
safety included.
"""

from __future__ import annotations

import time

import numpy as np

from facesynth.runtime.feature_names import NAMES
from facesynth.runtime.landmarks import N_IBUG
from facesynth.runtime.profiles import Profile
from facesynth.runtime.profiles.learned import unpack
from facesynth.schemas.messages import Features
from facesynth.services.translator.core import Translator

FRAME_NS = 33_333_333


def frames_for(profile: Profile, frames: int, seed: int = 0) -> list[Features]:
    """``frames`` tracked Features messages at 30 fps that move everything ``profile`` reads."""
    rng = np.random.default_rng(seed)
    names = list(NAMES)
    low, high = -np.ones(len(names)), np.ones(len(names))
    if profile.learned is not None:
        names = profile.learned.inputs
        low, high = 2 * unpack(profile.learned.reach_low), 2 * unpack(profile.learned.reach_high)
    out = []
    for index in range(frames):
        raw = dict(zip(names, rng.uniform(low, high).tolist(), strict=True))
        named = dict(zip(names, rng.uniform(-1.0, 1.0, len(names)).tolist(), strict=True))
        out.append(
            Features(
                seq=index,
                t_capture_ns=index * FRAME_NS,
                t_media_ns=index * FRAME_NS,
                face=True,
                neutral_ready=True,
                deltas=rng.uniform(-0.1, 0.1, N_IBUG).tolist(),
                named=named,
                raw=raw,
            )
        )
    return out


def time_translator(profile: Profile, frames: int = 2000, seed: int = 0, runs: int = 5) -> float:
    """Milliseconds per frame of T with ``profile``: the median of ``runs`` runs."""
    messages = frames_for(profile, frames, seed)
    times = []
    for _ in range(runs):
        translator = Translator(profile)
        begun = time.perf_counter()
        for message in messages:
            translator.step(message)
        times.append((time.perf_counter() - begun) * 1000.0 / frames)
    return float(np.median(times))
