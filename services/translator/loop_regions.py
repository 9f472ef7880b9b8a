"""Which features each servo's closed-loop correction reads (issue 27), plain numpy.

The closed loop (:mod:`facesynth.services.translator.closed_loop`) corrects each frame's
commands by damped least squares through the refined self-model's Jacobian on the error between
the target and the robot's face. Over the whole face, a servo is moved for any feature it
touches, however slightly: on simhead18_neck the neck turned to mend the blinks, the cheeks and
the lower lips, which the tracker reads a little differently on a turned head (the neck's
Jacobian there is a third to two thirds of the cheek servos' own), and wherever the fit gave the
neck no region of its own head_yaw ρ fell from 0.65-0.67 open to 0.38 closed
(docs/learning.md).

:func:`owned_regions` gives each servo the features it *owns* in the babbled self-model at
neutral: those it moves by at least ``share`` of what the servo moving them most does, and
always the one it moves most itself. The loop's Jacobian keeps each servo's column on those
features alone (one solve, as cheap as the whole face's). :func:`region_groups` is the other
way, for a regional inverse's regions (``LoopOptions.regional``, off): one solve per distinct
region, each servo taking its share of its own.
"""

from __future__ import annotations

import numpy as np

__all__ = ["owned_regions", "region_groups"]


def owned_regions(jacobian: np.ndarray, share: float) -> np.ndarray:
    """(servos, features) bools from a self-model's Jacobian (features, servos): servo ``s``
    owns feature ``f`` where ``|J[f, s]| >= share · max_s' |J[f, s']|`` and ``J[f, s] != 0``,
    and always its own largest ``|J[:, s]|`` (a servo moving nothing owns its first feature);
    ``share`` 0 gives every servo every feature. ValueError (one line) for a ``share`` outside [0,
    1] or a Jacobian that is empty or not finite."""
    if not 0.0 <= share <= 1.0:
        raise ValueError(f"closed loop: region share {share!r} is outside [0, 1]")
    size = np.abs(np.asarray(jacobian, dtype=np.float64))
    if size.ndim != 2 or not size.size:
        raise ValueError(f"closed loop: a Jacobian of shape {size.shape} has no servos")
    if not np.isfinite(size).all():
        raise ValueError("closed loop: the self-model's Jacobian at neutral is not finite")
    owned = size >= share * size.max(axis=1, keepdims=True)
    if share > 0:
        owned &= size > 0
    owned[np.argmax(size, axis=0), np.arange(size.shape[1])] = True
    out: np.ndarray = owned.T
    return out


def region_groups(
    regions: np.ndarray | None, n_servos: int, n_features: int, enabled: bool
) -> tuple[np.ndarray, np.ndarray] | None:
    """The regions the correction solves for: each distinct row of ``regions`` (servos,
    features) as a 0/1 mask of features, (regions, features), and each servo's region's index;
    None when every servo reads the whole face (one solve), ``regions`` is None or not
    ``enabled``; ValueError for ``regions`` of another shape."""
    if regions is None:
        return None
    regions = np.asarray(regions, dtype=bool)
    if regions.shape != (n_servos, n_features):
        raise ValueError(
            f"closed loop: regions of shape {regions.shape} do not fit {n_servos} servos and "
            f"{n_features} features"
        )
    if not enabled or regions.all():
        return None
    masks, index = np.unique(regions, axis=0, return_inverse=True)
    return masks.astype(np.float64), index.reshape(-1)
