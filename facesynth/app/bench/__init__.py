"""Benchmarks printed by ``facesynth bench``: the chain, the tracker, the smoothing."""
