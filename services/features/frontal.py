"""The paper's 68 points free of head rotation, through the tracker's 3D mesh (pure numpy).

The paper (section 2.2.2) removes rotation, translation and scale with the two outer eye
corners, which takes out only what happens in the image plane: when the head turns or nods,
the 2D distances to the nose tip shrink on the side turned away (the bundled video's laugh,
turned up to 24 degrees to her left and 15 degrees chin-up since her first second, read as
the brows lowered). With a 3D mesh the whole rotation can be taken out:

* :func:`frontalized`: the 68 points, with their depth (the mesh's, through the iBUG table), are
  moved rigidly onto the performer's neutral mesh: rotation, scale and shift from a
  least-squares fit (Kabsch/Umeyama) of the vertices expressions hardly move
  (``pose.STABLE_VERTICES``: forehead, nose bridge, eye corners, cheekbones), so they read as
  the camera would have seen them with the head held as at the neutral;
* :func:`paper_frame`: those points in the eye-corner frame of the *neutral's* outer eye
  corners. A laugh moves the eye corners (the cheeks push them), so a frame set by each
  frame's own corners scaled the laugh's distances with its expression (the left brow read
  +0.41 of its travel); the fit's scale comes from the stable vertices instead.

Before a neutral mesh is known (F's first second, re-read once it is), and for a mesh the fit
cannot use, only the yaw is undone, in each frame's own eye-corner frame (``pose.unturned``);
without a mesh (or without depth) the frame is the paper's 2D one.
"""

from __future__ import annotations

import contextlib

import numpy as np

from facesynth.runtime.ibug_mesh import ibug68_depth
from facesynth.services.features.frame import normalise
from facesynth.services.features.pose import (
    STABLE_VERTICES,
    MeshReference,
    PoseError,
    Similarity,
    apply,
    similarity_fit,
    unturned,
)

__all__ = ["frontalized", "paper_frame"]

_STABLE = np.asarray(STABLE_VERTICES)


def frontalized(
    ibug: np.ndarray,
    mesh: np.ndarray,
    reference: MeshReference,
    transform: Similarity | None = None,
) -> np.ndarray:
    """The 68 image points (68, 2) moved rigidly from the head's pose in ``mesh`` (468, 3) to
    its pose in the neutral mesh of ``reference`` (image coordinates): the head's rotation,
    position and distance since the neutral taken out. ``transform``: that fit when the
    caller has it (``reference.fits(mesh)[0]``). Raise
    :class:`~facesynth.services.features.pose.PoseError` for a mesh the fit cannot use."""
    if transform is None:
        transform = similarity_fit(mesh[_STABLE], reference.stable_target)
    lifted = np.empty((len(ibug), 3))  # the points with their depth
    lifted[:, :2] = ibug
    lifted[:, 2] = ibug68_depth(mesh)
    moved: np.ndarray = apply(transform, lifted)[:, :2]
    if not np.isfinite(moved).all():
        raise PoseError("the frontalised points are not finite")
    return moved


def paper_frame(
    ibug: np.ndarray,
    mesh: np.ndarray | None = None,
    reference: MeshReference | None = None,
    transform: Similarity | None = None,
) -> np.ndarray:
    """The 68 points in the eye-corner face frame (:func:`normalise`), the head's rotation taken
    out first when there is a mesh: against the neutral mesh ``reference`` when known
    (:func:`frontalized`, in the neutral's eye-corner frame; ``transform``: its fit, if known),
    else its yaw alone (``pose.unturned``, in the points' own). A mesh with no usable pose
    leaves the points as they are."""
    if mesh is not None:
        with contextlib.suppress(PoseError):
            if reference is not None:
                moved = frontalized(ibug, mesh, reference, transform)
                return normalise(moved, reference.ibug68)
            ibug = unturned(np.column_stack([ibug, ibug68_depth(mesh)]), mesh)
    return normalise(ibug)
