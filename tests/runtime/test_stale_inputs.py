"""The stages' input queues after an upstream stall: inputs captured too long ago are dropped.

P, F and T each take their input from a queue (facesynth.runtime.service.serve_transform); an
input whose frame was captured longer ago than the stage's limit when its turn comes is not
worked on: it is counted in the stage's stats (``stale``), said once per run of them, and the
stage goes on with fresh frames. P and F know no profile and use the profiles' default limit;
T uses its profile's ``max_command_age_s``. Virtual time: the shells run on a FakeClock, and the
frames name this host as their capture host (so their age is exact from the first).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import msgspec
import pytest

from facesynth.app.data import sample_openface_csv
from facesynth.runtime import keys
from facesynth.runtime.capture_age import DEFAULT_MAX_AGE_S
from facesynth.runtime.clock_host import clock_host
from facesynth.runtime.profiles import Profile, ServoSpec
from facesynth.runtime.service import ServiceContext
from facesynth.runtime.testing import StageRun
from facesynth.schemas.messages import Features, Frame, Points
from facesynth.services.features.core import FeatureProcessor
from facesynth.services.features.service import serve_features
from facesynth.services.points.backends.openface import OpenFaceConfig, OpenFaceReplay
from facesynth.services.points.service import serve_points
from facesynth.services.translator.core import Translator
from facesynth.services.translator.service import serve_translator

MS = 1_000_000
HOST = clock_host()
#: A profile whose commands may be a second old: T's limit is its profile's.
SLOW = Profile(
    name="slow",
    servos=[
        ServoSpec(
            name="jaw", channel=0, min_us=1000, neutral_us=1500, max_us=2000, feature="jaw_open"
        )
    ],
    max_command_age_s=1.0,
)


def frame(seq: int, t_capture_ns: int, host: str = HOST) -> Frame:
    return Frame(
        seq=seq,
        t_capture_ns=t_capture_ns,
        t_media_ns=seq * 33 * MS,
        width=640,
        height=480,
        encoding="none",
        capture_host=host,
    )


def points(seq: int, t_capture_ns: int, host: str = HOST) -> Points:
    return Points(
        seq=seq,
        t_capture_ns=t_capture_ns,
        t_media_ns=seq * 33 * MS,
        face=False,
        image_width=640,
        image_height=480,
        capture_host=host,
    )


def features(seq: int, t_capture_ns: int, host: str = HOST) -> Features:
    return Features(
        seq=seq,
        t_capture_ns=t_capture_ns,
        t_media_ns=seq * 33 * MS,
        face=True,
        neutral_ready=True,
        named={"jaw_open": 0.5},
        capture_host=host,
    )


@dataclass(frozen=True)
class Stage:
    name: str
    body: Callable[[ServiceContext], Any]
    consumes: keys.Stage
    publishes: keys.Stage
    message: Callable[..., msgspec.Struct]
    limit_s: float


STAGES = [
    Stage(
        "points",
        lambda ctx: serve_points(
            ctx, OpenFaceReplay(OpenFaceConfig(csv=str(sample_openface_csv()), loop=True))
        ),
        "input",
        "points",
        frame,
        DEFAULT_MAX_AGE_S,
    ),
    Stage(
        "features",
        lambda ctx: serve_features(ctx, FeatureProcessor()),
        "points",
        "features",
        points,
        DEFAULT_MAX_AGE_S,
    ),
    Stage(
        "translator",
        lambda ctx: serve_translator(ctx, Translator(SLOW)),
        "features",
        "servo_commands",
        features,
        SLOW.max_command_age_s,
    ),
]


@pytest.mark.parametrize("stage", STAGES, ids=[stage.name for stage in STAGES])
async def test_a_stall_s_backlog_is_dropped_where_it_waits_and_fresh_frames_go_on(
    stage: Stage, caplog: pytest.LogCaptureFixture
) -> None:
    async with StageRun(stage.body, service=stage.name) as run:
        now = run.clock.time_ns
        await run.send(stage.consumes, stage.message(0, now() - 20 * MS))
        await run.advance(3.0)  # upstream stalled; then its backlog comes, oldest first
        limit_ns = round(stage.limit_s * 1e9)
        await run.send(stage.consumes, stage.message(1, now() - 3_000 * MS))
        await run.send(stage.consumes, stage.message(2, now() - limit_ns - MS))
        await run.send(stage.consumes, stage.message(3, now() - limit_ns + MS))  # just within
        await run.send(stage.consumes, stage.message(4, now() - 5 * MS))
        out = [message.seq for message in run.messages(stage.publishes)]
        assert out == [0, 3, 4]
        assert run.ctx.stats.stale == 2 and run.ctx.stats.rejected == 0
        said = [r.message for r in caplog.records if "dropping frames this old" in r.message]
        assert len(said) == 1 and "captured 3.00 s ago" in said[0]
        assert any("fresh frames again: dropped 2" in r.message for r in caplog.records)


@pytest.mark.parametrize("stage", STAGES, ids=[stage.name for stage in STAGES])
async def test_inputs_without_a_capture_host_are_never_dropped_for_their_age(stage: Stage) -> None:
    # An older sender, a replayed recording, a --fast sensor: the capture stamps are no live
    # clock (here a minute old), and the frames wait for credit by design.
    async with StageRun(stage.body, service=stage.name) as run:
        for seq in range(3):
            await run.send(stage.consumes, stage.message(seq, run.clock.time_ns() - 60 * 10**9, ""))
        assert [message.seq for message in run.messages(stage.publishes)] == [0, 1, 2]
        assert run.ctx.stats.stale == 0


@pytest.mark.parametrize("stage", STAGES, ids=[stage.name for stage in STAGES])
async def test_each_stage_passes_the_capture_host_on(stage: Stage) -> None:
    async with StageRun(stage.body, service=stage.name) as run:
        await run.send(stage.consumes, stage.message(0, run.clock.time_ns(), HOST))
        assert run.messages(stage.publishes)[-1].capture_host == HOST
