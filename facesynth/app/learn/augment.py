"""The fit's use of the face's regions: recombined training faces, where they help.

The regions come from a session's sweeps
(:func:`facesynth.app.learn.regions.regions_from_sweeps`). :class:`Recombination` adds
``FitOptions.recombined`` faces recombined from the region poses
(:mod:`facesynth.app.learn.recombine`) to the inverse model's training poses when the
session babbled the regions (``MIN_REGION_POSES``): a session whose only poses that move one
region are its sweeps (the plain plan's) is fitted as before, on its own poses (the report
says so).

Measured (``python -m facesynth.app.learn.compare --ways adaptive``, 620 poses of the
adaptive plan, effective held-out command error on 160 other uniform poses): 2000 faces
recombined from about 200 region poses gave 0.136 / 0.138 on simhead16_reversed /
simhead16_stiff against 0.131 / 0.128 without; recombined from the sweeps alone (an earlier
version), 0.101 / 0.126 / 0.131 on simhead16 / _reversed / _stiff against 0.111 / 0.131 /
0.128. Within what one babbling tells apart, and no better: hence off by default
(``FitOptions.recombined = 0``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from facesynth.app.learn.models import FitOptions
from facesynth.app.learn.recombine import babbled_units, recombine, region_pools
from facesynth.app.learn.regions import Regions

#: Recombine only from a session with at least this many region poses (a pose moving one
#: region's servos, not a sweep): the adaptive plan's (:mod:`facesynth.app.learn.adaptive`).
MIN_REGION_POSES = 50


@dataclass(frozen=True)
class Recombination:
    """A fit's poses: ``t`` (n, d) faces relative to the neutral, ``u`` (n, S) commands, and
    the inverse model's ``x`` (standardized ``t`` by ``standard`` = (mean, scale)) and ``y``
    (the ``live`` servos' commands clipped into ``bounds`` = (low, high))."""

    t: np.ndarray
    u: np.ndarray
    x: np.ndarray
    y: np.ndarray
    standard: tuple[np.ndarray, np.ndarray]
    bounds: tuple[np.ndarray, np.ndarray]
    live: np.ndarray

    def rows(
        self, regions: Regions, rows: np.ndarray, options: FitOptions
    ) -> tuple[np.ndarray, np.ndarray]:
        """``x`` / ``y`` of ``rows``, and ``options.recombined`` faces recombined from them."""
        t_new, u_new = recombine(
            self.t[rows], self.u[rows], self.units(regions), options.recombined, options.seed
        )
        if not len(t_new):
            return self.x[rows], self.y[rows]
        mean, scale = self.standard
        low, high = self.bounds
        return (
            np.vstack([self.x[rows], (t_new - mean) / scale]),
            np.vstack([self.y[rows], np.clip(u_new[:, self.live], low, high)]),
        )

    def units(self, regions: Regions) -> tuple[tuple[int, ...], ...]:
        """What is recombined: the regions, merged where the babbling moved them together."""
        return babbled_units(regions.groups, self.u)

    def helps(
        self, regions: Regions, train: np.ndarray, kinds: np.ndarray, options: FitOptions
    ) -> tuple[bool, str]:
        """Whether to add recombined faces (the training poses hold at least
        ``MIN_REGION_POSES`` region poses), and a line for the report ("" when the regions
        leave nothing to recombine)."""
        units = self.units(regions)
        if len(units) < 2 or options.recombined < 1:
            return False, ""
        u, babbled = self.u[train], np.asarray(kinds)[train] == "random"
        alone = set().union(*(set(pool.tolist()) for pool in region_pools(u, units)))
        count = int(sum(babbled[row] for row in alone))
        if count < MIN_REGION_POSES:
            return False, (
                f"recombined faces left out: {count} region poses (fewer than "
                f"{MIN_REGION_POSES}): the sweeps alone are not recombined"
            )
        return True, f"{options.recombined} training faces recombined from {count} region poses"
