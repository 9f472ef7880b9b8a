"""The 68-point iBUG / CLM landmark view of the 468-vertex face mesh.

Each iBUG point is a fixed weighted mean of one or two mesh vertices, stored in the package data
file ``ibug68_from_mesh468.json`` (see that file's ``description`` for how it was derived). The
tracker (P) gives the 68 points of its mesh through it, and F takes their depth from it
(``ibug68_depth``) to turn them out of a head yaw.

iBUG numbering (0-based): 0-16 jaw contour from the subject's right (image left) to left,
17-21 right brow, 22-26 left brow, 27-30 nose bridge to tip (30 = tip), 31-35 nostrils,
36-41 right eye (36 = outer corner), 42-47 left eye (45 = outer corner), 48-59 outer lip
(48 = right corner, 54 = left corner), 60-67 inner lip.
"""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path

import numpy as np

__all__ = [
    "MAPPING_FILE",
    "NUM_POINTS",
    "ibug68_depth",
    "load_mapping",
    "mapping_matrix",
    "mesh_to_ibug68",
]

NUM_POINTS = 68
MAPPING_FILE: Path = Path(__file__).resolve().parent / "ibug68_from_mesh468.json"


def load_mapping(path: Path | str = MAPPING_FILE) -> list[tuple[list[int], list[float]]]:
    """Read and validate a mapping file: per iBUG point, (vertex indices, weights).

    Raises:
        ValueError: wrong number of points, bad vertex index, or weights not summing to 1.
    """
    data = json.loads(Path(path).read_text(encoding="utf-8"))
    points = data["points"]
    if len(points) != NUM_POINTS:
        raise ValueError(f"{path}: expected {NUM_POINTS} points, found {len(points)}")
    out = []
    for i, p in enumerate(points):
        verts = [int(v) for v in p["vertices"]]
        weights = [float(w) for w in p["weights"]]
        if not verts or len(verts) != len(weights):
            raise ValueError(f"{path}: point {i}: vertices and weights differ in length")
        if any(not 0 <= v < 468 for v in verts):
            raise ValueError(f"{path}: point {i}: vertex index out of range")
        if abs(sum(weights) - 1.0) > 1e-6:
            raise ValueError(f"{path}: point {i}: weights sum to {sum(weights)}, not 1")
        out.append((verts, weights))
    return out


@lru_cache(maxsize=4)
def mapping_matrix(path: str = str(MAPPING_FILE)) -> np.ndarray:
    """The (68, 468) float32 matrix W with ``ibug68 = W @ mesh[:, :2]``."""
    w = np.zeros((NUM_POINTS, 468), np.float32)
    for i, (verts, weights) in enumerate(load_mapping(path)):
        for v, k in zip(verts, weights, strict=True):
            w[i, v] += k
    w.setflags(write=False)
    return w


@lru_cache(maxsize=4)
def _gather(path: str = str(MAPPING_FILE)) -> tuple[np.ndarray, np.ndarray]:
    """The mapping as (68, K) vertex indices and (68, K, 1) weights, padded with weight 0."""
    mapping = load_mapping(path)
    k = max(len(v) for v, _ in mapping)
    idx = np.zeros((NUM_POINTS, k), np.intp)
    w = np.zeros((NUM_POINTS, k, 1), np.float32)
    for i, (verts, weights) in enumerate(mapping):
        idx[i, : len(verts)] = verts
        w[i, : len(verts), 0] = weights
    return idx, w


def mesh_to_ibug68(mesh: np.ndarray) -> np.ndarray:
    """68 iBUG points (68, 2) float32 from a (468, >=2) mesh, same coordinates as the mesh."""
    m = np.asarray(mesh, dtype=np.float32)
    if m.ndim != 2 or m.shape[0] != 468 or m.shape[1] < 2:
        raise ValueError(f"expected a (468, 2|3) mesh, got {m.shape}")
    idx, w = _gather()
    out: np.ndarray = (m[idx, :2] * w).sum(axis=1)
    return out


def ibug68_depth(mesh: np.ndarray) -> np.ndarray:
    """The depth (68,) of the 68 iBUG points of a (468, 3) mesh: the mesh's z through the same
    weights as :func:`mesh_to_ibug68` (which gives their x and y)."""
    m = np.asarray(mesh, dtype=np.float64)
    if m.ndim != 2 or m.shape[0] != 468 or m.shape[1] < 3:
        raise ValueError(f"expected a (468, 3) mesh, got {m.shape}")
    idx, w = _gather()
    out: np.ndarray = (m[idx, 2] * w[:, :, 0]).sum(axis=1)
    return out
