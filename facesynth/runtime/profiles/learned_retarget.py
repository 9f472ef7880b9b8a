"""How T retargets the performer's face into a learned robot's reach: the options a learned
profile file carries (``retarget``, from file version 2) and the rule for the features the
robot can show. T runs them in :mod:`services.translator.retarget`; they live here, with the
file's other parts, so the loader can check them and ``facesynth profile show`` describe them.
"""

from __future__ import annotations

import msgspec
import numpy as np


class Retarget(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """How T turns the performer's face into the robot's target face
    (:mod:`services.translator.retarget`; a file without it retargets as files fitted before
    it did). ``gain``: the share of the performer's change (from her neutral) the robot is
    asked for, before it is clipped into the robot's reach (Emo's 0.9, the default here; a new
    fit writes :data:`FIT_GAIN`, 1.1); ``tau_s``: the time
    constant of the running estimate of how much the performer moves each feature;
    ``min_weight``: the least weight a feature she hardly moves keeps in the plan (weights are
    in [min_weight, 1]); ``show_noise``: an input is one the robot can show when its
    ``noise`` (what the commands do not explain) is at most this share of its spread while
    babbling (``input_scale``): 0.85, the commands explain 28 % of its variance or more (a
    feature only jitter moves: none; on simhead16 and simhead16_reversed, each babbled 600
    times, every feature but one the commands move: 33 % or more, the most nonlinear
    blendshapes included); ``region_floor``:
    how far a face region's change may be scaled down as one, keeping its shape, before its
    features are clipped one by one (1: not at all, each feature is clipped on its own; on
    simhead16 scaling regions down to 0.5 kept ρ and cost amplitude: 0.47 against 0.55);
    ``extent``: the performer's extent on a feature is taken as this many times her running
    root mean square change, and where it exceeds the robot's reach her change is scaled by
    reach / extent before the clip (0: never, Emo's clip alone; on simhead16 scaling gave
    ρ 0.59 against the clip's 0.57 at the same amplitude); 1.9: about her 95th percentile
    (her 95th percentile change is a median 1.85 times its root mean square over the
    features of the sample video; files fitted before 2026-11-27 carry 2.5, which scaled the
    target to 0.59 of her amplitude where 1.9 gives 0.67; on simhead16 and simhead16_stiff
    1.9 kept ρ within 0.005 while the robot's amplitude ratio rose from 0.47 to 0.52 and
    from 0.53 to 0.54); ``lead_s``: each command is led by its rate of change times this
    (s) against the head's lag, open loop only (:mod:`services.translator.lead`; 0, the
    default and what a fit writes: not led; on simhead16 0.1 s raised ρ from 0.59 to 0.62 and
    the amplitude ratio from 0.47 to 0.50 in a file asking for gain 0.9; a fit measures the
    head's own lag and reports it (:mod:`facesynth.app.learn.lag`), but led by it, in files
    asking for gain 1.1, ρ moved by -0.018 to +0.014 over five simulated heads and the amplitude in
    reach fell by 0.04 on simhead16_stiff, so it is not written: docs/learning.md, "The lead
    learned from the head's own lag")."""

    gain: float = 0.9
    tau_s: float = 10.0
    min_weight: float = 0.2
    show_noise: float = 0.85
    region_floor: float = 1.0
    extent: float = 1.9
    lead_s: float = 0.0


#: The share of the performer's change a new fit asks for (``Retarget.gain`` as the fit writes
#: it; files carry their gain, so a file fitted before 2026-11-27 keeps Emo's 0.9, the default
#: of a ``retarget`` table without one). More than her change within the robot's reach: the
#: plan, T's smoothing and the head's lag keep about 0.8 of the target's amplitude, so at 0.9
#: the robot showed 0.72-0.77 of her change in its reach (docs/learning.md, "Asking for more
#: than her change"). On simhead16 / _stiff / _reversed / seed:0 / seed:1, 1.1 raised that to
#: 0.82 / 0.82 / 0.76 / 0.81 / 0.80 with mean ρ changed by -0.004 / -0.008 / +0.017 / 0 /
#: -0.003; targets are still clipped into the reach box.
FIT_GAIN = 1.1


def fitted_retarget() -> Retarget:
    """The retargeting options a new fit writes: the defaults, asking for :data:`FIT_GAIN`."""
    return Retarget(gain=FIT_GAIN)


def showable(scale: np.ndarray, noise: np.ndarray | None, ratio: float) -> np.ndarray:
    """Per input, whether the robot can show it: its ``noise`` is at most ``ratio`` times its
    spread while babbling, ``scale`` (every input when the noise is unknown)."""
    if noise is None:
        return np.ones(len(scale), dtype=bool)
    shown: np.ndarray = noise <= ratio * scale
    return shown
