"""Retargeting into what the robot can reach: the pure core, in plain numpy (issue 27).

A learned profile's inputs are the features the robot moved while babbling; for each, the file
holds the robot's reach (``reach_low`` .. ``reach_high``: the 1st and 99th percentiles of its
babbled face, relative to its neutral, raw units) and, from version 2, its ``noise`` (the
spread of what the robot's commands did not explain while babbling). Per frame, from the
performer's change ``d`` (``Features.raw``: relative to her own neutral, the same units as the
robot's):

* **Targets** (:meth:`Retargeter.targets`): ``t = clip(gain · s · d, reach_low, reach_high)``,
  Emo's retargeting (``gain`` × the performer's change, clipped into the box the babbling
  spanned; Emo's gain is 0.9, a new fit writes 1.1, ``learned_retarget.FIT_GAIN``),
  scaled to the robot's reach first: ``s = min(1, reach / extent)``, the performer's extent
  being ``extent`` times her running root mean square change (the weights' estimate below)
  and ``reach`` the robot's on that side, so a feature she moves beyond what the robot can
  show is scaled into its reach rather than flattened at its edge (``extent`` 0: the clip
  alone).
  Each face region (:func:`region`: head, gaze, eyes, brows, cheeks, mouth) can be taken as
  one vector (``region_floor`` < 1): where a feature of the region would be clipped, the
  whole region's change is scaled down first, to ``region_floor`` at most, so the region keeps
  its shape (both brows raised together stay together) instead of one feature flattening
  while the others go on. By default (1) each feature is clipped on its own: on simhead16 the
  regions' shape bought no correlation and cost amplitude.
* **Features the robot cannot show** (:func:`facesynth.runtime.profiles.learned.showable`):
  an input whose ``noise`` (the part of it the robot's commands did not explain while
  babbling) is more than ``show_noise`` (0.85) of its spread is one the robot did not move: only
  the camera's jitter did (a blink on a head without lids, a head turn without a neck, read a
  little through the skin). Its target is the robot's neutral (0) and its weight 0: it is left
  out of the plan instead of being traded against features the robot can show.
* **Weights** (:class:`MovementWeights`): each feature's weight in the plan is how much the
  performer moves it: a running root mean square of ``d`` (time constant ``tau_s``, time given
  as data), in units of the robot's own spread of that feature (``input_scale``), bounded to
  ``[min_weight, 1]`` (:data:`FULL_WEIGHT` of the robot's spread or more: 1; a change beyond
  :data:`OUTLIER` times that counts as that much). Until a frame has been seen every showable
  feature weighs 1.
"""

from __future__ import annotations

import math

import numpy as np

from facesynth.runtime.profiles.learned import Retarget, showable

__all__ = ["MovementWeights", "Retargeter", "region", "showable"]

#: The face regions, and the name prefixes that put a feature in one (first match wins).
REGIONS: dict[str, tuple[str, ...]] = {
    "head": ("head_",),
    "gaze": ("gaze_", "eyeLook"),
    "eyes": ("eye_open", "lid_", "eyeBlink", "eyeSquint", "eyeWide"),
    "brows": ("brow",),
    "cheeks": ("cheek", "noseSneer"),
    "mouth": ("jaw", "lip", "mouth"),
}
#: A side of a feature whose reach is under this share of its whole reach takes no part in
#: a region's scaling (it is clipped on its own).
ONE_SIDE = 0.25
#: A change counts for at most this many times the full weight's level (an outlier of the
#: tracker stops counting after a few time constants).
OUTLIER = 10.0
#: A performer moving a feature by this many of the robot's standard deviations (RMS) gives
#: it the full weight 1.
FULL_WEIGHT = 1.0


def region(name: str) -> str:
    """The face region of feature ``name`` (``"other"`` when no prefix matches)."""
    for label, prefixes in REGIONS.items():
        if name.startswith(prefixes):
            return label
    return "other"


class Retargeter:
    """The performer's change → the robot's target face and each feature's weight."""

    def __init__(
        self,
        inputs: list[str],
        low: np.ndarray,
        high: np.ndarray,
        scale: np.ndarray,
        noise: np.ndarray | None,
        options: Retarget,
    ) -> None:
        """``low`` / ``high``: the robot's reach per input (``low <= 0 <= high``); ``scale``:
        its spread per input (``input_scale``, > 0); ``noise``: its jitter (None: unknown)."""
        self.low, self.high = low, high
        self.gain, self.floor, self.extent = options.gain, options.region_floor, options.extent
        self.shown = showable(scale, noise, options.show_noise)
        self.gains = np.where(self.shown, self.gain, 0.0)  # 0: not shown, its neutral
        labels = [region(name) for name in inputs]
        self.regions = [np.array([lab == g for lab in labels]) for g in sorted(set(labels))]
        self.weights = MovementWeights(scale, options.tau_s, options.min_weight, self.shown)

    def targets(self, change: np.ndarray) -> np.ndarray:
        """The robot's target per input for the performer's ``change`` (finite values; a
        missing one is 0, her neutral): within the reach, 0 where the robot cannot show it."""
        wanted = change * self.gains
        if self.extent > 0:  # the performer's extent scaled into the robot's reach
            extent = self.extent * self.weights.rms()
            reach = np.where(wanted >= 0, self.high, -self.low)
            over = extent > reach  # (so extent > 0 there)
            if over.any():
                wanted = wanted * np.divide(reach, extent, out=np.ones_like(reach), where=over)
        if self.floor >= 1.0:  # (np.minimum/maximum: a fifth of np.clip's time)
            clipped: np.ndarray = np.minimum(np.maximum(wanted, self.low), self.high)
            return clipped
        bound = np.where(wanted >= 0, self.high, self.low)
        with np.errstate(all="ignore"):  # a tiny change: an infinite room
            room = np.where(np.abs(wanted) > 0, bound / wanted, np.inf)  # >= 0: same sign
        # a side the robot hardly reaches (a one-way actuator) is clipped, not shrunk toward
        room = np.where(np.abs(bound) > ONE_SIDE * (self.high - self.low), room, np.inf)
        shrink = np.ones_like(wanted)
        for members in self.regions:
            fit = float(np.min(room[members], initial=np.inf))
            shrink[members] = min(1.0, max(fit, self.floor))
        out: np.ndarray = np.clip(wanted * shrink, self.low, self.high)
        return out


class MovementWeights:
    """A running estimate of how much the performer moves each feature, as bounded weights.

    Per feature, an exponentially weighted mean of ``change²`` (each frame weighs
    ``1 - exp(-dt / tau_s)``, ``dt`` from the frames' own times; the first frame seen weighs
    fully), its root over the robot's spread ``scale`` / :data:`FULL_WEIGHT`, bounded to
    ``[min_weight, 1]``; 0 for features the robot cannot show. A frame whose time does not
    advance, and a feature missing from a frame, leave the estimate as it was."""

    def __init__(self, scale: np.ndarray, tau_s: float, min_weight: float, shown: np.ndarray):
        self.scale, self.tau_s, self.min_weight = scale, tau_s, min_weight
        self.shown = shown
        self.mask = shown.astype(np.float64)
        with np.errstate(over="ignore", divide="ignore"):  # extreme scales: inf
            self.inverse = 1.0 / (scale * FULL_WEIGHT)
            self.bound = OUTLIER * FULL_WEIGHT * scale  # a tracker's outlier weighs no more
        self.reset()

    def reset(self) -> None:
        """Forget the performance: every showable feature weighs 1 again."""
        self.mean_square = np.full(len(self.scale), np.inf)  # inf: no value yet
        self.t_ns: int | None = None

    def update(self, change: np.ndarray, t_ns: int) -> np.ndarray:
        """Take one frame's ``change`` (NaN: missing) at ``t_ns``; the weights after it."""
        if self.t_ns is not None and t_ns <= self.t_ns:
            return self.weights()
        seen = np.isfinite(change)
        keep = 0.0 if self.t_ns is None else math.exp(-(t_ns - self.t_ns) / 1e9 / self.tau_s)
        self.t_ns = t_ns
        old = self.mean_square
        # extreme scales (a valid file's 1e300) overflow to inf: read as no value yet
        with np.errstate(over="ignore"):
            square = np.square(np.minimum(np.maximum(change, -self.bound), self.bound))
            if keep > 0.0:  # (inf, no value yet, stays inf and is replaced below)
                square = np.where(np.isinf(old), square, keep * old + (1.0 - keep) * square)
        self.mean_square = np.where(seen, square, old)
        return self.weights()

    def rms(self) -> np.ndarray:
        """Each feature's running root mean square change (0 before its first value)."""
        out: np.ndarray = np.sqrt(np.where(np.isinf(self.mean_square), 0.0, self.mean_square))
        return out

    def weights(self) -> np.ndarray:
        """Each feature's weight now (see the class)."""
        with np.errstate(invalid="ignore", over="ignore"):  # inf * 0: NaN, fmax's min
            level = np.sqrt(self.mean_square) * self.inverse  # inf (no value yet): 1 below
        out: np.ndarray = np.fmin(np.fmax(level, self.min_weight), 1.0) * self.mask
        return out
