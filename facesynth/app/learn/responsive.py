"""Each servo's responsive range: the part of its travel over which the face still changes.

Pure numpy, from the babbling data itself. Some actuators move the face one way only (a cable
that pulls skin: the other half of the servo's travel is slack) or stop moving it before the
end of their travel (the skin or the linkage saturates). Any command in such a part gives the
same face, so no camera-based learner can tell those commands apart, and driving a servo there
only wears it and winds up slack. :func:`responsive_range` finds, per servo, the normalized
range ``[low, high]`` (``-1 <= low <= 0 <= high <= 1``) outside which nothing moves.

The rule, from the **sweep** samples (that servo alone off neutral, a few steps each way) and
the repeated **neutral** samples (their spread is the noise):

* Each input's threshold is ``max(NOISE_K · noise, MIN_CHANGE)``: ``noise`` is the standard
  deviation of that input over the neutral samples (raw units, relative to the neutral), so it
  holds both the camera's jitter and the drift between neutral visits. A face *differs* from
  another when some input differs by more than its threshold. A side's *movement* at a step is
  the largest ``|change| / threshold`` over the inputs, against the neutral face.
* **Slack.** A side none of whose steps, the full command included, moves the face (every
  movement <= 1) is slack: its bound is 0, *provided* the other side clearly moves the face
  (movement >= ``CLEAR``). A servo both of whose sides look still is weak, not slack: the
  sweeps cannot tell, its range stays [-1, 1] (truly dead servos are the fit's business).
* **Saturation.** On a side that clearly moves (its farthest step >= ``CLEAR``), walking in
  from the end: while at least two steps remain and the face at the last step (the full
  travel) equals the face a step further in (the change <= 1 threshold *and* <=
  ``SATURATED_SHARE`` of the side's farthest movement), the range ends at that step. Always
  against the full travel's face, not the neighbouring step's: with fine sweeps (six steps)
  a steady response changes the face by less than a threshold from one step to the next.
* A level swept more than once (repeated sweeps) counts as the mean of its faces.
* A side without sweep steps, or without neutral samples to measure the noise, keeps its full
  travel (1).

This is conservative: a range is only cut where no input moved beyond four times the neutral
noise, and never inward of a step that moved the face. Random poses are not used: a sweep
isolates one servo, a random pose mixes sixteen. With the default three steps each way the
bounds are 0, 1/3, 2/3 or 1.

Its limit, measured: one sample per sweep step is little. On today's simhead16_reversed
session the right outer cheek's slack side moved 0.96 of the threshold (its coupling into the
lip corner and lids) and was cut; the bench's mean rho on that head fell 0.03 with that cut
alone. The neutral samples' own largest movement there is 1.25, so the sweeps cannot tell
that side from noise; more sweep steps or repeated sweeps would.
"""

from __future__ import annotations

import numpy as np

#: An input moved when it changed by more than this many neutral noises …
NOISE_K = 4.0
#: … and by more than this (raw feature units, as ``facesynth.app.learn.sweeps``).
MIN_CHANGE = 0.01
#: A side moves the face *clearly* when its movement reaches this (thresholds).
CLEAR = 2.0
#: The last step of a saturated side changes the face by at most this share of its movement.
SATURATED_SHARE = 0.25
#: Commands closer to neutral than this count as at neutral (normalized).
AT_NEUTRAL = 1e-6


def thresholds(t: np.ndarray, kinds: np.ndarray) -> np.ndarray | None:
    """Per input, the change that counts as a movement (None: fewer than 2 neutral samples)."""
    neutral = t[kinds == "neutral"]
    if len(neutral) < 2:
        return None
    out: np.ndarray = np.maximum(NOISE_K * neutral.std(axis=0), MIN_CHANGE)
    return out


def _side(
    levels: np.ndarray, faces: np.ndarray, rest: np.ndarray, threshold: np.ndarray
) -> tuple[float, bool]:
    """``(end, clear)`` of one side: ``levels`` |u| ascending, ``faces`` their rows; ``end``
    is where the face stops changing (0: slack), ``clear`` whether the side clearly moves."""
    moved = np.array([np.max(np.abs(f - rest) / threshold) for f in faces])
    if not np.any(moved > 1.0):
        return 0.0, False
    farthest = float(moved[-1])
    if farthest < CLEAR:
        return 1.0, False
    end = len(levels) - 1
    while end >= 1:  # the face at the full travel against the face a step further in
        step = float(np.max(np.abs(faces[-1] - faces[end - 1]) / threshold))
        if step > 1.0 or step > SATURATED_SHARE * farthest:
            break
        end -= 1
    return (1.0 if end == len(levels) - 1 else float(levels[end])), True


def responsive_range(
    t: np.ndarray, u: np.ndarray, kinds: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``(low, high)``, each (S,): every servo's responsive range in normalized commands.

    ``t`` (n, d): the inputs, raw, relative to the robot's neutral; ``u`` (n, S): normalized
    commands; ``kinds`` (n,): each sample's kind (``"neutral"``, ``"sweep"``, ``"random"``).
    See the module for the rule.
    """
    n_servos = u.shape[1]
    low, high = -np.ones(n_servos), np.ones(n_servos)
    kinds = np.asarray(kinds)
    threshold = thresholds(t, kinds)
    if threshold is None:
        return low, high
    rest = np.median(t[kinds == "neutral"], axis=0)
    off = np.abs(u) > AT_NEUTRAL
    alone = (kinds == "sweep") & (off.sum(axis=1) == 1)
    for servo in range(n_servos):
        rows = alone & off[:, servo]
        sides: dict[float, tuple[float, bool]] = {}
        for sign in (-1.0, 1.0):
            mine = rows & (np.sign(u[:, servo]) == sign)
            if not mine.any():
                sides[sign] = (1.0, False)
                continue
            # a level swept more than once: the mean of its faces (less noise)
            levels, at = np.unique(np.abs(u[mine, servo]), return_inverse=True)
            faces = np.array(
                [t[mine][at.reshape(-1) == k].mean(axis=0) for k in range(len(levels))]
            )
            sides[sign] = _side(levels, faces, rest, threshold)
        (below, below_clear), (above, above_clear) = sides[-1.0], sides[1.0]
        if below == 0.0 and not above_clear:
            below = 1.0  # both sides still or faint: weak, not slack
        if above == 0.0 and not below_clear:
            above = 1.0
        low[servo], high[servo] = -below, above
    return low, high


def clip_commands(u: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """Normalized commands ``u`` (..., S) clipped into each servo's responsive range."""
    out: np.ndarray = np.clip(u, low, high)
    return out
