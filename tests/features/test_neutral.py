"""services.features.neutral: the per-name medians of a neutral's named features."""

from __future__ import annotations

import math

import numpy as np

from facesynth.services.features.neutral import medians


def test_medians_are_numpys_median_of_each_list() -> None:
    """One median of the matrix of full-length lists, the shorter ones alone: each value is
    ``float(np.median(v))`` bit for bit, odd and even counts, NaN included, names in order."""
    rng = np.random.default_rng(7)
    for count in range(1, 26):
        values = {f"f{i}": rng.normal(size=count).tolist() for i in range(30)}
        values["short"] = rng.normal(size=max(1, count - 2)).tolist()
        values["nan"] = [math.nan, *rng.normal(size=count - 1).tolist()]
        got = medians(values)
        assert list(got) == list(values)
        for name, listed in values.items():
            want = float(np.median(listed))
            assert got[name] == want or (math.isnan(got[name]) and math.isnan(want)), name
    assert medians({}) == {}
