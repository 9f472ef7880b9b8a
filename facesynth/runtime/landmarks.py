"""The iBUG/CLM 68-point scheme (0-based), as the paper's Table 1 numbers it.

Right and left are the performer's own: the right eye (36-41) appears on the image's left.
"""

from __future__ import annotations

from typing import Final

import numpy as np

IBUG68: Final = "ibug68"
MESH468: Final = "mesh468"
#: Face Landmarker v2: the 468 mesh vertices (same numbering as ``mesh468``), then the
#: performer's right iris (centre + 4 contour points), then the left one; x, y, z.
MESH478: Final = "mesh478"
IRIS10: Final = "iris10"

N_IBUG = 68
NOSE_TIP = 30
RIGHT_EYE_OUTER = 36
LEFT_EYE_OUTER = 45

_PAIRS: Final = (
    [(i, 16 - i) for i in range(8)]
    + [(17 + i, 26 - i) for i in range(5)]
    + [(31, 35), (32, 34)]
    + [(36, 45), (37, 44), (38, 43), (39, 42), (40, 47), (41, 46)]
    + [(48, 54), (49, 53), (50, 52), (55, 59), (56, 58), (60, 64), (61, 63), (65, 67)]
)


def _mirror_permutation() -> np.ndarray:
    perm = np.arange(N_IBUG)
    for a, b in _PAIRS:
        perm[a], perm[b] = b, a
    return perm


#: ``points[MIRROR]`` swaps every point with its left-right counterpart.
MIRROR: Final[np.ndarray] = _mirror_permutation()
