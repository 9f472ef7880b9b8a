"""``bench robot --closed-loop``: a learned profile driving a simulated head with its camera in
the loop, in process and in virtual time, beside the same profile in open loop.

:class:`ClosedRobotLoop` (:mod:`facesynth.app.engine.closed_robot_loop`, shared with
``render --robot-head --closed-loop``) is :class:`~.robot.RobotLoop` whose F output is also
handed back to T, as ``--robot-camera`` does live: T sees each face one frame later, as a real
camera would show it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence

from facesynth.app.engine.closed_robot_loop import ClosedRobotLoop
from facesynth.app.engine.robot_loop import Head
from facesynth.runtime.profiles import Profile
from facesynth.services.translator.closed_loop import LoopOptions, LoopState

from .robot import Performance, RobotBench, play
from .robot_compare import FeatureStream
from .robot_variants import Runner, bench_variants

__all__ = ["CLOSED_SUFFIX", "ClosedRobotLoop", "bench_closed", "closed_runner", "run_closed"]

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
    return bench_variants(
        performance,
        heads,
        profiles,
        open_head,
        {CLOSED_SUFFIX: closed_runner(options)},
        progress=progress,
        learn=learn,
    )


def closed_runner(options: LoopOptions | None = None) -> Runner:
    """A :data:`~.robot_variants.Runner` that closes the loop (with ``options``)."""

    def run(performance: Performance, profile: Profile, head: Head) -> FeatureStream:
        return run_closed(performance, profile, head, options)[0]

    return run
