"""The simulated head's neck: the whole rendered head turned in 3D (yaw, pitch) by one warp.

The photo's landmarks carry depth (Face Landmarker's z), so the face is a relief. Here it is a
depth map over the whole head, in the face frame (x toward the performer's left, y up, z toward
the camera; unit = the inter-ocular distance, IOD; z = 0 at the outer eye corners):

* on the face, the landmarks' own depth (a Gaussian-weighted mean of the nearest ones);
* beyond it (hair, ears, the sides of the head), the face's relief continued smoothly (wider
  weights) and flattened to the pivot's depth toward the head's outline (:data:`HEAD`, an
  ellipse, and :data:`FLATTEN`).

A turn rotates every point of that relief about the neck's pivot (:data:`PIVOT`: behind the
eyes, at the height of the ears, as the atlas joint is): pitched about the horizontal axis,
then turned about the vertical one (a pitch stage on a yaw stage), and projected back
orthographically. The displacement fades to nothing outside the head's outline
(:data:`FADE`), so the background stays where it is. The image is resampled through the
inverse of that displacement, found by a few fixed-point steps (source(q) = q - d(source(q)))
on a coarse grid (:data:`STEP` pixels; the turn is smooth), as :mod:`.renderer` does for
expressions: a turn adds one remap of the whole image and three of an 80x80 grid to a frame.
Hair and background near the outline smear at the largest turns (the far cheek is squeezed,
never hidden): good enough for a tracker, not a portrait.

Activation ±1 of ``neck_yaw`` / ``neck_pitch`` is ±:data:`NECK_DEGREES` of that effect:
positive yaw turns the head toward the performer's left, positive pitch lifts the chin (the
signs of F's ``head_yaw`` and ``head_pitch``).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Final

import cv2
import numpy as np

from facesynth.app.simhead.faces import Face

__all__ = ["NECK_DEGREES", "Neck"]

#: Degrees of each neck effect at activation ±1 (activations are clipped to ±1.5).
NECK_DEGREES: Final = {"neck_yaw": 25.0, "neck_pitch": 15.0}
#: The pivot of both rotations in the face frame (IOD): on the midline, 0.55 below the outer
#: eye corners and 0.9 behind them.
PIVOT: Final = (0.0, -0.55, -0.9)
#: The head's outline, an ellipse in the face frame (IOD): centre height, half width, half
#: height (the hair's top and the chin are within it).
HEAD: Final = (-0.1, 0.95, 1.55)
#: Outline radii (1 = the ellipse) over which the relief flattens to the pivot's depth, and
#: over which the turn fades into the still background.
FLATTEN: Final = (0.8, 1.15)
FADE: Final = (1.0, 1.4)
#: Widths of the Gaussian weights that spread the landmarks' depth: over the face, and the
#: smooth continuation of the relief beyond it (IOD).
DEPTH_SIGMA: Final = (0.08, 0.3)
#: The displacement is computed on a grid this many pixels apart, then interpolated.
STEP: Final = 4
#: Fixed-point steps inverting the displacement.
INVERSE_STEPS: Final = 4


def _smoothstep(value: np.ndarray, edges: tuple[float, float]) -> np.ndarray:
    """1 below ``edges[0]``, 0 above ``edges[1]``, smooth between."""
    share = np.clip((value - edges[0]) / (edges[1] - edges[0]), 0.0, 1.0)
    out: np.ndarray = 1.0 - share * share * (3.0 - 2.0 * share)
    return out


class Neck:
    """The head turned in 3D (see the module doc); built once per face (~0.1 s)."""

    def __init__(self, face: Face) -> None:
        self.face = face
        h, w = face.image.shape[:2]
        origin, x_axis, up = face.axes()
        self._origin, self._x_axis, self._up, self._iod = origin, x_axis, up, face.iod
        self._size = (w, h)
        # coarse grid points at the centres of STEP x STEP blocks (as cv2.resize samples)
        ys, xs = np.mgrid[0 : -(-h // STEP), 0 : -(-w // STEP)].astype(np.float64)
        xs, ys = xs * STEP + (STEP - 1) / 2.0, ys * STEP + (STEP - 1) / 2.0
        rel_x, rel_y = xs - origin[0], ys - origin[1]
        x = (rel_x * x_axis[0] + rel_y * x_axis[1]) / face.iod
        y = (rel_x * up[0] + rel_y * up[1]) / face.iod
        centre_y, half_w, half_h = HEAD
        radius = np.sqrt((x / half_w) ** 2 + ((y - centre_y) / half_h) ** 2)
        local = face.local()[:468]
        self._points_z = self.depth(face.points)
        relief = self._points_z[:468] - PIVOT[2]
        sums = {sigma: [np.zeros_like(x), np.zeros_like(x)] for sigma in DEPTH_SIGMA}
        for (lx, ly), lz in zip(local, relief, strict=True):
            d2 = (x - lx) ** 2 + (y - ly) ** 2
            for sigma, (weights, depths) in sums.items():
                weight = np.exp(-d2 / (2.0 * sigma * sigma))
                weights += weight
                depths += weight * lz
        (near_w, near_d), (wide_w, wide_d) = sums.values()
        wide = wide_d / np.maximum(wide_w, 1e-12)
        background = float(np.exp(-4.5))
        near = (near_d + background * wide) / (near_w + background)
        z = PIVOT[2] + near * _smoothstep(radius, FLATTEN)
        self._xyz = np.stack([x, y, z], axis=2).astype(np.float32)
        self._mask = _smoothstep(radius, FADE).astype(np.float32)
        self._grid = np.stack([xs, ys], axis=2).astype(np.float32)
        rows, columns = np.mgrid[0:h, 0:w].astype(np.float32)
        self._pixels = np.stack([columns, rows], axis=2)

    def depth(self, points: np.ndarray) -> np.ndarray:
        """Each landmark's depth in the face frame (IOD toward the camera, 0 at the outer
        eye corners), from the photo's own z (pixels, away from the camera)."""
        corners = float(self.face.points[[33, 263], 2].mean())
        depth: np.ndarray = -(points[:, 2] - corners) / self.face.iod
        return depth

    @staticmethod
    def angles(activations: Mapping[str, float]) -> tuple[float, float]:
        """(yaw, pitch) in radians under ``activations``."""
        out = []
        for name, degrees in NECK_DEGREES.items():
            value = float(np.clip(activations.get(name, 0.0), -1.5, 1.5))
            out.append(np.radians(value * degrees))
        return out[0], out[1]

    @staticmethod
    def _rotate(xyz: np.ndarray, yaw: float, pitch: float) -> np.ndarray:
        """Face-frame points (..., 3) turned about :data:`PIVOT`: the pitch stage rides on the
        yaw stage (the head pitched, then the pitched head turned), so the turn is F's yaw
        then pitch (intrinsic) and shows no roll."""
        p = xyz - np.asarray(PIVOT, xyz.dtype)
        cy, sy, cp, sp = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch)
        y = p[..., 1] * cp + p[..., 2] * sp
        z = -p[..., 1] * sp + p[..., 2] * cp
        x = p[..., 0] * cy + z * sy
        z = -p[..., 0] * sy + z * cy
        return np.stack([x, y, z], axis=-1) + np.asarray(PIVOT, xyz.dtype)

    def _to_image(self, dx: np.ndarray, dy: np.ndarray) -> np.ndarray:
        """Face-frame displacements (IOD) as image pixels (..., 2)."""
        x_axis, up = self._x_axis, self._up
        return self._iod * np.stack(
            [dx * x_axis[0] + dy * up[0], dx * x_axis[1] + dy * up[1]], axis=-1
        )

    def landmarks(self, moved: np.ndarray, activations: Mapping[str, float]) -> np.ndarray:
        """The (478, 2) image landmarks ``moved`` (by expressions) turned by the neck."""
        yaw, pitch = self.angles(activations)
        if yaw == 0.0 and pitch == 0.0:
            return moved
        rel = moved - self._origin
        x = (rel @ self._x_axis) / self._iod
        y = (rel @ self._up) / self._iod
        xyz = np.stack([x, y, self._points_z], axis=1)
        turned = self._rotate(xyz, yaw, pitch)
        out: np.ndarray = moved + self._to_image(turned[:, 0] - x, turned[:, 1] - y)
        return out

    def turn(self, image: np.ndarray, activations: Mapping[str, float]) -> np.ndarray:
        """``image`` (the head's face, BGR) with the head turned; itself when not turned."""
        yaw, pitch = self.angles(activations)
        if yaw == 0.0 and pitch == 0.0:
            return image
        turned = self._rotate(self._xyz, yaw, pitch)
        move = self._to_image(
            turned[..., 0] - self._xyz[..., 0], turned[..., 1] - self._xyz[..., 1]
        )
        field = (move * self._mask[..., None]).astype(np.float32)
        half = (STEP - 1) / 2.0
        source = self._grid - field
        for _ in range(INVERSE_STEPS - 1):  # sample the field at the source, in grid units
            at = ((source - half) / STEP).astype(np.float32)
            back = cv2.remap(
                field, at[..., 0], at[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT
            )
            source = self._grid - back
        w, h = self._size
        back = cv2.resize(self._grid - source, (w, h), interpolation=cv2.INTER_LINEAR)
        where = (self._pixels - back).astype(np.float32)
        return cv2.remap(
            image, where[..., 0], where[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE
        )
