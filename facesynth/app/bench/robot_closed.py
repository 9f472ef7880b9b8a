"""``bench robot --closed-loop``: a learned profile driving a simulated head with its camera in
the loop, in process and in virtual time, beside the same profile in open loop.

:class:`ClosedRobotLoop` (:mod:`facesynth.app.engine.closed_robot_loop`, shared with
``render --robot-head --closed-loop``) is :class:`~.robot.RobotLoop` whose F output is also
handed back to T, as ``--robot-camera`` does live: T sees each face one frame later, as a real
camera would show it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence

import msgspec

from facesynth.app.engine.closed_robot_loop import ClosedRobotLoop
from facesynth.app.engine.robot_loop import Head
from facesynth.runtime.profiles import Profile
from facesynth.services.translator.closed_loop import LoopOptions, LoopState

from .robot import Performance, RobotBench, load, measure, play, run_profile
from .robot_compare import FeatureStream

__all__ = ["CLOSED_SUFFIX", "ClosedRobotLoop", "bench_closed", "run_closed"]

#: How a closed-loop run of a profile is named beside its open-loop run.
CLOSED_SUFFIX = " (closed loop)"


def run_closed(
    performance: Performance,
    profile: Profile,
    head: Head,
    options: LoopOptions | None = None,
    state: LoopState | None = None,
) -> tuple[FeatureStream, LoopState]:
    """The robot's raw features for every performer frame with the loop closed, and what the
    loop learned; T with the performer's calibration, if any (as the open run has it)."""
    loop = ClosedRobotLoop(
        profile,
        head,
        fps=performance.fps,
        options=options,
        state=state,
        calibration=performance.calibration,
    )
    return play(performance, loop), loop.loop.state


def bench_closed(
    performance: Performance,
    heads: Iterable[str],
    profiles: Sequence[str],
    open_head: Callable[[str], Head],
    *,
    options: LoopOptions | None = None,
    progress: Callable[[str], None] | None = None,
    learn: Callable[[str], list[Profile]] | None = None,
) -> RobotBench:
    """Every profile on every head as ``bench robot`` runs it, and each learned one again with
    the loop closed (named ``NAME (closed loop)``), side by side; ``learn`` as
    :func:`~.robot.measure` takes it (each profile it learns runs open and closed too)."""

    def closed_name(profile: Profile) -> str:
        return profile.name + CLOSED_SUFFIX

    def run(head: str, profile: Profile) -> FeatureStream:
        if profile.name.endswith(CLOSED_SUFFIX):
            original = msgspec.structs.replace(
                profile, name=profile.name.removesuffix(CLOSED_SUFFIX)
            )
            return run_closed(performance, original, open_head(head), options)[0]
        return run_profile(performance, profile, open_head(head))

    def open_and_closed(name: str) -> list[Profile]:
        profile = load(name)
        if profile.learned is None:
            return [profile]
        return [profile, msgspec.structs.replace(profile, name=closed_name(profile))]

    def learn_both(head: str) -> list[Profile]:
        assert learn is not None
        mine = learn(head)
        return mine + [msgspec.structs.replace(p, name=closed_name(p)) for p in mine]

    loaded = [p for name in profiles for p in open_and_closed(name)]
    both = learn_both if learn is not None else None
    return measure(performance, heads, loaded, run, progress=progress, learn=both)
