"""The closed loop's integral action: the observed face against the target of the frame that
produced it (issue 27), plain numpy.

The robot's face a camera sees at ``t`` was made by commands sent earlier: the actuators slew,
the skin lags, the camera and its tracker take their time. Measured on simhead16 in
``bench robot --closed-loop``, the robot's face follows T's targets best 3 frames (0.125 s)
later. Comparing that face with the target of *now* would read every movement as an error (the
face is late, not wrong) and push the commands the wrong way while the face moves; so the
face captured at ``t`` is compared with the target of the frame sent at or before
``t - delay_s`` (:meth:`IntegralAction.planned` keeps each frame's target).

Their difference ``e = x - y`` (standardized units; each feature bounded to ``MAX_ERROR``,
missing ones 0; weighted as the plan weighs them) is taken into commands through the refined
self-model's Jacobian at the commands that made the face, by damped least squares, and
accumulated with ``integral_gain``: ``z ← leak · z + gain · Δ``. What the model-based
correction leaves (a face that stays weaker or offset however the model is refined) is taken up
by ``z`` over a few frames. Anti-windup:

* ``z`` stays within ``±max_correction`` per servo;
* a servo whose command was at an end of its responsive range when the face was made does not
  integrate further toward that end (a target the servo cannot reach does not wind up);
* ``leak`` (< 1) lets go of what a performance no longer asks for (targets it cannot reach);
* when the face is lost, ``z`` is dropped (the correction then returns to the open loop at the
  loop's bounded step, never in a jump).
"""

from __future__ import annotations

from collections import deque

import numpy as np

__all__ = ["IntegralAction"]

#: Targets remembered for pairing faces with (a few seconds at camera rate).
HISTORY = 128


class IntegralAction:
    """The integral of the delayed observed error, in normalized command units."""

    def __init__(
        self,
        n_servos: int,
        *,
        gain: float,
        leak: float,
        delay_s: float,
        bound: float,
        max_error: float,
    ) -> None:
        """``gain``: the share of each observation's correction taken (0: off); ``leak``: what
        ``z`` keeps of itself per observation; ``delay_s``: how long after a frame's command its
        face is seen; ``bound``: ``z``'s bound per servo; ``max_error``: an observed feature's
        error counts for at most this much (standardized units)."""
        self.gain, self.leak, self.bound, self.max_error = gain, leak, bound, max_error
        self.delay_ns = round(delay_s * 1e9)
        self.z = np.zeros(n_servos)
        self.eye = np.eye(n_servos)
        # (sent at, the frame's standardized target, its feature weights or None)
        self.targets: deque[tuple[int, np.ndarray, np.ndarray | None]] = deque(maxlen=HISTORY)
        #: Observations integrated so far.
        self.updates = 0

    def reset(self) -> None:
        """Forget the targets and the integral."""
        self.targets.clear()
        self.z = np.zeros_like(self.z)

    def drop(self) -> None:
        """The face is lost: the integral is dropped (the targets are kept)."""
        self.z = np.zeros_like(self.z)

    def planned(self, x: np.ndarray, weights: np.ndarray | None, t_ns: int) -> None:
        """The frame sent at ``t_ns`` aimed at the standardized face ``x``."""
        if self.gain <= 0:
            return
        if self.targets and t_ns < self.targets[-1][0]:
            self.targets.clear()  # the clock went back: what came before pairs with nothing
        self.targets.append((t_ns, np.array(x, dtype=np.float64), weights))

    def target_at(self, t_capture_ns: int) -> tuple[np.ndarray, np.ndarray | None] | None:
        """The target of the frame that made the face captured at ``t_capture_ns`` (the
        latest sent at or before ``delay_s`` earlier; None: none that early)."""
        made_by = t_capture_ns - self.delay_ns
        for sent_ns, x, weights in reversed(self.targets):
            if sent_ns <= made_by:
                return x, weights
        return None

    def update(
        self,
        face: np.ndarray,
        t_capture_ns: int,
        jacobian: np.ndarray,
        damping: float,
        u: np.ndarray,
        low: np.ndarray,
        high: np.ndarray,
    ) -> None:
        """Integrate the face captured at ``t_capture_ns`` (standardized, NaN: missing),
        made by the commands ``u`` (normalized) whose refined self-model's Jacobian is
        ``jacobian``; ``low`` / ``high``: the responsive range."""
        if self.gain <= 0:
            return
        paired = self.target_at(t_capture_ns)
        if paired is None:
            return
        x, weights = paired
        with np.errstate(all="ignore"):
            present = np.isfinite(face) & np.isfinite(x)
            error = np.clip(np.where(present, x - face, 0.0), -self.max_error, self.max_error)
            weighted = jacobian if weights is None else jacobian * weights[:, None]
            normal = weighted.T @ jacobian + damping * self.eye
            gradient = weighted.T @ error
            if not (np.isfinite(normal).all() and np.isfinite(gradient).all()):
                return
            try:
                delta = np.linalg.solve(normal, gradient)
            except np.linalg.LinAlgError:
                return
        if not np.isfinite(delta).all():
            return
        # Anti-windup: a servo already at an end does not integrate further toward it.
        at_end = ((u >= high - 1e-9) & (delta > 0)) | ((u <= low + 1e-9) & (delta < 0))
        delta = np.where(at_end, 0.0, delta)
        self.z = np.clip(self.leak * self.z + self.gain * delta, -self.bound, self.bound)
        self.updates += 1
