"""A plan rehearsed on the robot itself (``facesynth plan --driver … --camera …``).

What the self-model gets wrong, the robot shows: each round, the robot is posed at the planned
frames' commands, one after another, and its settled face is read through its own camera, as
``facesynth learn`` reads a babbled pose (:mod:`facesynth.app.learn.shell`: the camera, the
tracker, F on the robot's face with its neutral learned first, the control interface with the
servo driver, on an embedded router of this process; a pose is taken once the face holds still,
a lost face pauses at neutral). :class:`RobotRehearsal` is the ``look`` that
:func:`~facesynth.app.plan.performance.plan_performance` rehearses through.

Each round is recorded as a babbling session of its own beside the plan
(``PLAN.round0.mcap`` …: the poses, features, commands and states; ``facesynth learn
--fit-only`` reads it like any session), so a stopped or killed rehearsal loses at most the
pose in progress. ``look_every`` poses every Kth planned frame only (and the last): what the
self-model got wrong is interpolated in time between them, a round then takes a Kth of the time.
A first Ctrl-C ends the round in progress (the robot back at neutral, its file completed) and
the rehearsal with it: the plan keeps the best round already shown.
"""

from __future__ import annotations

import logging
import sys
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import msgspec
import numpy as np

from facesynth.app.learn.core import BabbleOptions, Babbler, Budget
from facesynth.app.learn.plan import Pose
from facesynth.app.learn.progress import Progress
from facesynth.app.learn.session import metadata, read_session
from facesynth.app.plan.performance import pulses
from facesynth.runtime.profiles import Profile

__all__ = ["RIG", "RobotRehearsal", "ShownPoses", "looked_rows", "normalized", "round_path"]

log = logging.getLogger("facesynth.plan")

#: The robot's own rig during a rehearsal (an embedded router of this process).
RIG = "self"


def normalized(profile: Profile, positions: Mapping[str, float]) -> tuple[float, ...]:
    """Pulses by servo as normalized values, one per servo of ``profile`` in its order (−1 at
    its lower limit, 0 at neutral, 1 at its upper; a servo not named: 0), the inverse of
    :func:`~facesynth.app.learn.plan.to_pulses`."""
    values = []
    for spec in profile.servos:
        pulse = spec.clamp(positions.get(spec.name, spec.neutral_us))
        span = (
            (spec.max_us - spec.neutral_us)
            if pulse >= spec.neutral_us
            else (spec.neutral_us - spec.min_us)
        )
        values.append(0.0 if span <= 0 else (pulse - spec.neutral_us) / span)
    return tuple(values)


class ShownPoses:
    """The babbler's plan during a rehearsal: the given poses, in order (kind ``rehearsal``)."""

    def __init__(self, profile: Profile, positions: list[dict[str, float]]) -> None:
        if not positions:
            raise ValueError("a rehearsal round shows one pose or more")
        self.poses = [
            Pose(index, "rehearsal", normalized(profile, p)) for index, p in enumerate(positions)
        ]

    def pose(self, index: int) -> Pose:
        """Pose ``index`` (the last one again past the end: the budget ends the round there)."""
        return self.poses[min(index, len(self.poses) - 1)]

    def seen(self, pose: Pose, features: Mapping[str, float]) -> None:
        """The poses are given: nothing to learn from the faces."""


def looked_rows(frames: int, every: int) -> list[int]:
    """The planned frames a round poses: every ``every``-th from the first, and the last."""
    if every < 1:
        raise ValueError(f"look at every 1st frame or sparser, not every {every}")
    return sorted({*range(0, frames, every), frames - 1})


def round_path(plan: str | Path, round_: int) -> Path:
    """Where round ``round_``'s session goes: beside the plan, ``PLAN.round<K>.mcap``."""
    path = Path(plan)
    return path.with_name(f"{path.stem}.round{round_}.mcap")


@dataclass
class RobotRehearsal:
    """The robot shown a plan's commands, a round per call (see the module): ``profile`` (the
    learned profile, ``profile_ref`` its name or path for the control interface), the
    camera's, tracker's and servo driver's ``configs`` (``sensor``, ``points``, ``control``),
    where the plan goes (``plan``: the rounds' sessions beside it), how poses settle
    (``options``), every how many planned frames a pose (``look_every``) and every how many
    camera frames one is recorded (``frame_every``; 0: none)."""

    profile: Profile
    profile_ref: str
    configs: dict[str, msgspec.Struct]
    plan: Path
    options: BabbleOptions
    look_every: int = 1
    frame_every: int = 30
    #: Rounds shown so far.
    rounds: int = 0

    def __call__(self, commands: np.ndarray) -> np.ndarray | None:
        """The robot's settled faces at ``commands`` (planned frames × the learned outputs):
        the learned inputs, raw (NaN rows: frames not posed, or a face lost); None when the
        round was stopped (Ctrl-C)."""
        from facesynth.app.learn.session import SessionFile
        from facesynth.app.learn.shell import (
            RECORD_KEYS,
            BabbleShell,
            babble,
            on_embedded_router,
        )
        from facesynth.app.robot_rig import build_parts
        from facesynth.runtime.bus.zenoh_bus import ZenohOptions
        from facesynth.runtime.service import run_async

        learned = self.profile.learned
        assert learned is not None  # (the plan checked it)
        rows = looked_rows(len(commands), self.look_every)
        shown = pulses(self.profile, np.asarray(commands)[rows])
        path = round_path(self.plan, self.rounds)
        log.info(
            "rehearsal round %d: %d poses of %d planned frames (%s)",
            self.rounds,
            len(rows),
            len(commands),
            path,
        )
        started = time.monotonic()
        babbler = Babbler(
            self.profile,
            ShownPoses(self.profile, shown),
            budget=Budget(poses=len(rows)),
            options=self.options,
        )
        progress = Progress(sys.stderr, first=0, total=len(rows), started_s=started)
        shell = BabbleShell(babbler, seed=0, progress=progress, on_neutral=lambda: None)
        record = [k for k in RECORD_KEYS if self.frame_every or k != "input"]
        meta = metadata(RIG, self.profile, 0, record)
        meta.update({"rehearsal_round": str(self.rounds), "frame_every": str(self.frame_every)})
        session = SessionFile(path, meta, None)
        parts = build_parts(self.profile_ref, RIG, self.profile, self.configs)

        result = run_async(
            on_embedded_router(
                ["tcp/127.0.0.1:0"],
                ZenohOptions(mode="router"),
                RIG,
                lambda bus: babble(
                    bus, RIG, parts, shell, session, frame_every=self.frame_every, record=record
                ),
            )
        )
        self.rounds += 1
        if result.interrupted:
            log.warning("rehearsal stopped in round %d (%s kept)", self.rounds - 1, path)
            return None
        faces = np.full((len(commands), len(learned.inputs)), np.nan)
        for sample in read_session(path).samples:
            if 0 <= sample.seq < len(rows):
                faces[rows[sample.seq]] = [
                    sample.features.get(name, np.nan) for name in learned.inputs
                ]
        return faces
