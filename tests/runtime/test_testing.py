"""facesynth.runtime.testing: one stage on the in-memory bus, in virtual time, for any stage."""

from __future__ import annotations

import asyncio

import pytest

from facesynth.app.data import sample_openface_csv
from facesynth.runtime import keys
from facesynth.runtime.clock import FAKE_EPOCH_NS, FakeClock, IdleTimeout
from facesynth.runtime.profiles import load_profile
from facesynth.runtime.service import ServiceContext
from facesynth.runtime.testing import StageRun
from facesynth.schemas.messages import Features, Frame, Points, ServoCommands
from facesynth.services.features.core import FeatureProcessor
from facesynth.services.features.service import serve_features
from facesynth.services.points.backends.openface import OpenFaceConfig, OpenFaceReplay
from facesynth.services.points.service import serve_points
from facesynth.services.translator.core import Translator
from facesynth.services.translator.service import serve_translator

MS = 1_000_000


def tick(seq: int) -> Frame:
    return Frame(
        seq=seq,
        t_capture_ns=FAKE_EPOCH_NS,
        t_media_ns=round(seq * 1e9 / 30),
        width=640,
        height=480,
        encoding="none",
    )


def no_face(seq: int) -> Points:
    return Points(
        seq=seq, t_capture_ns=1, t_media_ns=seq, face=False, image_width=640, image_height=480
    )


async def test_three_stages_in_a_row_each_on_its_own_run() -> None:
    """P, F and T shells, each fed what the one before published (usable for any stage)."""
    replay = OpenFaceReplay(OpenFaceConfig(csv=str(sample_openface_csv())))
    points = StageRun(lambda c: serve_points(c, replay), service="points")
    features = StageRun(lambda c: serve_features(c, FeatureProcessor()), service="features")
    translator = StageRun(
        lambda c: serve_translator(c, Translator(load_profile("paper16"))), service="translator"
    )
    async with points, features, translator:
        for seq in range(40):
            await points.send("input", tick(seq))
            await points.advance(1 / 30)
        for message in points.messages("points"):
            await features.send("points", message)
        for message in features.messages("features"):
            await translator.send("features", message)
        out = translator.messages("servo_commands")
    assert [m.seq for m in points.messages("points")] == list(range(40))
    assert all(isinstance(m, Points) and m.face for m in points.messages("points"))
    assert all(isinstance(m, Features) for m in features.messages("features"))
    assert [m.seq for m in out] == list(range(40))
    assert all(isinstance(m, ServoCommands) and m.profile == "paper16" for m in out)
    # Each frame was answered at the instant it was sent: frame n after n steps of 1/30 s.
    step = round(1e9 / 30)
    assert [p.t_ns for p in points.on("points")] == [n * step for n in range(40)]


async def test_records_the_stages_publications_decoded_with_their_virtual_time() -> None:
    run = StageRun(lambda c: serve_features(c, FeatureProcessor()), service="features")
    async with run:
        await run.advance(0.25)
        await run.send("points", no_face(7))
        [publication] = run.on("features")
        assert publication.t_ns == 250 * MS and publication.t == 0.25
        assert publication.key == keys.stage_key("test", "features")
        assert isinstance(publication.message, Features) and publication.message.seq == 7
        # What the test sent is not in the record.
        assert [p.topic for p in run.published] == ["features"]


async def test_counts_rejected_input() -> None:
    run = StageRun(lambda c: serve_features(c, FeatureProcessor()), service="features")
    async with run:
        await run.send("points", b"not msgpack")
        await run.send("points", tick(1))  # a Frame where Points belong
        assert run.ctx.stats.rejected == 2 and run.messages("features") == []


async def test_stats_every_interval_and_a_last_one_when_stopped() -> None:
    run = StageRun(
        lambda c: serve_features(c, FeatureProcessor()), service="features", stats_interval=0.5
    )
    async with run:
        assert run.alive()
        await run.send("points", no_face(0))
        await run.advance(1.2)
    stats = run.on("stats")
    assert [p.t_ns for p in stats] == [500 * MS, 1000 * MS, 1200 * MS]
    assert [s.message.note for s in stats] == ["", "", "stopped"]
    assert stats[0].message.t_ns == FAKE_EPOCH_NS + 500 * MS
    assert stats[0].message.service == "features" and stats[0].message.rss_mb > 0
    assert stats[-1].message.published == 1 and stats[-1].message.uptime_s == 1.2
    assert stats[0].key == keys.stats_key("test", "features", "one")
    assert not run.alive()


async def test_finish_returns_what_the_body_returned() -> None:
    async def body(ctx: ServiceContext) -> str:
        ctx.ready()
        await ctx.clock.sleep(3.0)
        return "done"

    async with StageRun(body, service="sensor") as run:
        assert await run.finish(timeout=3.0) == "done" and run.now == 3.0


async def test_finish_says_when_the_body_does_not_end_in_time() -> None:
    async def body(ctx: ServiceContext) -> None:
        await ctx.clock.sleep(10.0)

    async with StageRun(body, service="sensor") as run:
        with pytest.raises(IdleTimeout):
            await run.finish(timeout=2.0)


async def test_an_error_in_the_body_reaches_the_test() -> None:
    async def body(ctx: ServiceContext) -> None:
        await ctx.clock.sleep(1.0)
        raise KeyError("broken stage")

    run = StageRun(body, service="features")
    await run.start()
    await run.advance(1.0)
    with pytest.raises(KeyError, match="broken stage"):
        await run.stop()


async def test_an_undecodable_publication_fails_the_test() -> None:
    async def body(ctx: ServiceContext) -> None:
        ctx.bus.publish(ctx.key("features"), b"\xc1")
        await asyncio.Event().wait()

    async with StageRun(body, service="features") as run:
        with pytest.raises(AssertionError, match="undecodable features"):
            run.messages("features")


async def test_a_run_starts_once_and_shares_the_clock_it_was_given() -> None:
    clock = FakeClock(start_ns=5 * MS)

    async def body(ctx: ServiceContext) -> None:
        await asyncio.Event().wait()

    run = StageRun(body, service="features", clock=clock)
    assert run.ctx.clock is clock and run.network.clock is clock
    with pytest.raises(RuntimeError, match="not started"):
        await run.finish(1.0)
    async with run:
        with pytest.raises(RuntimeError, match="already running"):
            await run.start()
