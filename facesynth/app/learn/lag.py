"""How late the head's face follows its commands: the response lag a fit measures and reports.

Pure, time as data. A **transition** is one command change seen by the camera: the command's
progress from its old value to its new one (0 → 1; a step is 1 from the first instant, a paced
ramp rises) and the face frame by frame, with the settled faces before and after. The face's
progress is its change projected onto its whole change, ``(x - before)·Δ / Δ·Δ`` with
``Δ = after - before``, so every feature the servo moves counts by how far it moves it. The
transition's lag is the area between the two progress curves, ``∫ (command - face) dt``: the
difference of their centroids in time, which is the mean delay of a linear response (a
first-order lag of τ: τ; a dead time d: d; a slew-limited step of size A: A / 2·slew). That is
the delay the phase lead of :mod:`facesynth.services.translator.lead` inverts to first order
(``u + lead_s · du/dt``), tracker and skin together, whatever the head's dynamics are. The
area is taken by trapezoids over the frames, which overstates a lag as short as a frame a little
(a first-order lag of 0.03 s at 30 frames a second reads 0.033 s).

A transition whose face moved by less than ``min_change`` (a servo the camera barely sees)
says nothing and gives ``None``. :func:`fitted_lead` reduces the per-servo lags to one lead
(``Retarget.lead_s``): the median over servos of each servo's median lag, within
``[0, MAX_LEAD_S]``. The fit reports it (:func:`lag_notes`) but does not write it: led by it,
the lead ρ of ``bench robot`` rose on three simulated heads of five (by 0.004-0.014) and fell
on the others (by 0.007 and 0.018), and the amplitude in reach fell by 0.04 on simhead16_stiff
(docs/learning.md, "The lead learned from the head's own lag"), so a new fit leaves T's lead
off (``lead_s`` 0).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = [
    "MAX_LEAD_S",
    "MIN_CHANGE",
    "Transition",
    "fitted_lead",
    "lag_notes",
    "servo_lags",
    "transition_lag",
]

#: The largest lead a fit writes (s): 0.2 s already overshot on simhead16 (docs/learning.md).
MAX_LEAD_S = 0.2
#: A transition whose face moved less than this (the norm of its change in raw feature units)
#: gives no lag: its progress would be the tracker's jitter.
MIN_CHANGE = 0.05


@dataclass(frozen=True)
class Transition:
    """One command change of ``servo`` and the face that followed it.

    ``t_s``: (n,) times of the frames (s, any origin, increasing); ``command``: (n,) the
    command's progress at each (0 before, 1 once at its new value); ``faces``: (n, F) the face's
    features at each (NaN where absent); ``before`` / ``after``: (F,) the settled faces.
    """

    servo: str
    t_s: np.ndarray
    command: np.ndarray
    faces: np.ndarray
    before: np.ndarray
    after: np.ndarray


def transition_lag(transition: Transition, min_change: float = MIN_CHANGE) -> float | None:
    """The transition's lag (s): the area between its command's and its face's progress
    (see the module); ``None`` when the face moved less than ``min_change`` or fewer than two
    frames have a face."""
    t = np.asarray(transition.t_s, dtype=np.float64)
    columns = np.isfinite(transition.before) & np.isfinite(transition.after)
    delta = (transition.after - transition.before)[columns]
    size = float(delta @ delta)
    if size < min_change**2:
        return None
    faces = transition.faces[:, columns]
    rows = np.all(np.isfinite(faces), axis=1)
    if rows.sum() < 2:
        return None
    face = (faces[rows] - transition.before[columns]) @ delta / size
    gap = np.asarray(transition.command, dtype=np.float64)[rows] - face
    times = t[rows]
    return float(np.sum((gap[1:] + gap[:-1]) * np.diff(times)) / 2.0)


def servo_lags(
    transitions: Sequence[Transition], min_change: float = MIN_CHANGE
) -> dict[str, float]:
    """Per servo, the median lag of its transitions that say one (servos with none left out)."""
    found: dict[str, list[float]] = {}
    for transition in transitions:
        lag = transition_lag(transition, min_change)
        if lag is not None:
            found.setdefault(transition.servo, []).append(lag)
    return {servo: float(np.median(lags)) for servo, lags in found.items()}


def fitted_lead(lags: Mapping[str, float]) -> float:
    """The lead a fit writes for these per-servo lags: their median within
    ``[0, MAX_LEAD_S]`` (0: no lag known, not led), rounded to the millisecond."""
    if not lags:
        return 0.0
    return round(float(np.clip(np.median(list(lags.values())), 0.0, MAX_LEAD_S)), 3)


def lag_notes(lags: Mapping[str, float]) -> list[str]:
    """The fit report's line about the measured lags (none when none was measured)."""
    if not lags:
        return []
    values = sorted(lags.values())
    return [
        f"response lag {np.median(values):.3f} s (median of {len(values)} servos, "
        f"{values[0]:.3f}-{values[-1]:.3f}); not led (retarget.lead_s 0; "
        f"lead_s {fitted_lead(lags):g} would lead by it)"
    ]
