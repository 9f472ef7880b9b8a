"""``bench robot`` with each learned profile also run another way, beside its open loop:
``--closed-loop`` (:mod:`.robot_closed`) and ``--planned`` (:mod:`.robot_planned`).

A variant is a suffix to the profile's name (``NAME (closed loop)``) and how to run it on a
head. Every learned profile, named or learned for the head (``--learn-poses``), runs open
loop first, then each variant in the order given; a written profile runs open loop only.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence

import msgspec

from facesynth.app.engine.robot_loop import Head
from facesynth.runtime.profiles import Profile

from .robot import Performance, RobotBench, load, measure, run_profile
from .robot_compare import FeatureStream

__all__ = ["Runner", "bench_variants", "every_way"]

#: Runs one (learned) profile on a head over the performance: the robot's raw features.
Runner = Callable[[Performance, Profile, Head], FeatureStream]


def bench_variants(
    performance: Performance,
    heads: Iterable[str],
    profiles: Sequence[str],
    open_head: Callable[[str], Head],
    variants: Mapping[str, Runner],
    *,
    progress: Callable[[str], None] | None = None,
    learn: Callable[[str], list[Profile]] | None = None,
) -> RobotBench:
    """Every profile on every head as ``bench robot`` runs it, and each learned one again
    each way of ``variants`` (suffix → runner; named ``NAME`` + suffix), side by side;
    ``learn`` as :func:`~.robot.measure` takes it (each profile it learns runs every way
    too)."""

    def run(head: str, profile: Profile) -> FeatureStream:
        for suffix, runner in variants.items():
            if profile.name.endswith(suffix):
                original = msgspec.structs.replace(profile, name=profile.name.removesuffix(suffix))
                return runner(performance, original, open_head(head))
        return run_profile(performance, profile, open_head(head))

    def learn_every_way(head: str) -> list[Profile]:
        assert learn is not None
        return [p for mine in learn(head) for p in every_way(mine, variants)]

    loaded = [p for name in profiles for p in every_way(load(name), variants)]
    both = learn_every_way if learn is not None else None
    return measure(performance, heads, loaded, run, progress=progress, learn=both)


def every_way(profile: Profile, suffixes: Iterable[str]) -> list[Profile]:
    """A learned profile, then a copy of it named with each variant's suffix (``NAME (closed
    loop)``); a written profile alone (it runs open loop only)."""
    if profile.learned is None:
        return [profile]
    return [profile, *(msgspec.structs.replace(profile, name=profile.name + s) for s in suffixes)]
