"""T's view of a performance, frame by frame: its targets, its plan's weights, its commands.

:func:`translate` runs a learned profile's translator core (:class:`LearnedTargets`, without
its smoothing) over F's output for each performer frame, in order (its running weights and
the performer's extent depend on the frames before).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from facesynth.runtime.profiles import Learned, Profile
from facesynth.runtime.profiles.learned import unpack
from facesynth.schemas.messages import Features
from facesynth.services.translator.learned import LearnedTargets

__all__ = ["Frames", "standardized", "translate"]

#: One value per performer frame (None: T had no target there).
Frames = list[np.ndarray | None]


def translate(
    profile: Profile, features: Sequence[Features]
) -> tuple[Frames, list[np.ndarray], list[np.ndarray]]:
    """Per performer frame (F's ``features``): T's target (the learned inputs, raw; None:
    none, no face or no neutral yet), its plan's weights and its unsmoothed command (the
    learned outputs, normalized; the last one held where there is no target). ValueError for
    a profile that is not learned."""
    targets = LearnedTargets(profile, {})
    held = np.zeros(len(targets.outputs))
    wanted: Frames = []
    weights: list[np.ndarray] = []
    commands: list[np.ndarray] = []
    for frame in features:
        tracking = frame.face and frame.neutral_ready and frame.raw
        t = targets.retarget(frame.raw, frame.named, frame.t_media_ns) if tracking else None
        if t is not None:
            u = targets.commands(t)
            held = np.where(np.isfinite(u), u, held)
        wanted.append(t)
        w = targets.plan_weights()
        weights.append(np.ones(len(targets.inputs)) if w is None else w.copy())
        commands.append(held.copy())
    return wanted, weights, commands


def standardized(learned: Learned, wanted: Frames) -> tuple[list[int], np.ndarray]:
    """The frames where T has a target (of :func:`translate`'s ``wanted``), and those targets
    as the learned models see them, standardized (frames × inputs)."""
    mean, scale = unpack(learned.input_mean), unpack(learned.input_scale)
    frames = [i for i, t in enumerate(wanted) if t is not None]
    return frames, np.array([(wanted[i] - mean) / scale for i in frames])
