"""The 68-point iBUG / CLM landmark view of the 468-vertex face mesh, for the tracker.

The mapping lives in ``facesynth.runtime.ibug_mesh`` (F reads the points' depth through it too);
these are its names as the tracker package has always exported them.
"""

from __future__ import annotations

from facesynth.runtime.ibug_mesh import (
    MAPPING_FILE,
    NUM_POINTS,
    load_mapping,
    mapping_matrix,
    mesh_to_ibug68,
)

__all__ = ["MAPPING_FILE", "NUM_POINTS", "load_mapping", "mapping_matrix", "mesh_to_ibug68"]
