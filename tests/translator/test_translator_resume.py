"""Translator.resume and the translator shell: T learns where the control interface reports the
servos before it resumes, so its next command never asks for a jump; and it stamps commands."""

from __future__ import annotations

from typing import Any

import msgspec
import pytest
from translator_fixtures import DT, feature_servo, features_at, profile_of

from facesynth.runtime.clock_host import clock_host
from facesynth.runtime.testing import StageRun
from facesynth.schemas.messages import ServoCommands
from facesynth.services.translator.core import Translator
from facesynth.services.translator.service import serve_translator

LIMITED = profile_of(
    feature_servo("jaw", 0, max_speed=3000.0),
    feature_servo("brow", 1, feature="brow_raise_inner_right"),  # no max_speed: catches up
    neutral_ramp_s=0.5,
)
OPEN = {"jaw_open": 1.0, "brow_raise_inner_right": 1.0}


def test_resume_starts_the_limiters_where_the_servos_are() -> None:
    translator = Translator(LIMITED)
    translator.resume({"jaw": 1800.0, "brow": 1200.0})
    first = translator.step(features_at(0, OPEN))
    assert first == {"jaw": 1800.0, "brow": 1200.0}  # the first frame starts the clock there
    second = translator.step(features_at(1, OPEN))
    assert second["jaw"] == pytest.approx(1800.0 + 3000 * DT, abs=1e-3)
    # The brow has no max_speed: it catches up at its full travel (1000 µs) per 0.5 s.
    assert second["brow"] == pytest.approx(1200.0 + 2000 * DT, abs=1e-3)


def test_without_resume_the_first_frame_jumps_to_its_target() -> None:
    """What a restarted translator did: its first command asked for the target at once."""
    first = Translator(LIMITED).step(features_at(0, OPEN))
    assert first == {"jaw": 2000.0, "brow": 2000.0}


def test_resume_clamps_and_fills_in_neutral_and_ignores_nonsense() -> None:
    translator = Translator(LIMITED)
    translator.resume({"jaw": 99999.0, "brow": float("nan"), "tail": 1.0})
    assert translator.step(features_at(0, OPEN)) == {"jaw": 2000.0, "brow": 1500.0}


def test_is_at_says_whether_resuming_would_change_the_limiters() -> None:
    translator = Translator(LIMITED)
    assert not translator.is_at(translator.neutral())  # nothing yet
    translator.resume({"jaw": 1700.0})
    translator.step(features_at(0, {}, face=False))  # no face: held still, heading to neutral
    assert translator.is_at({"jaw": 1700.0, "brow": 1500.0})
    assert not translator.is_at({"jaw": 1710.0, "brow": 1500.0})


# --- the shell ---------------------------------------------------------------------------------


def state(move: str, **positions: float) -> ServoCommands:
    return ServoCommands(
        seq=0, t_capture_ns=0, t_media_ns=0, face=False, profile="t", positions=positions, move=move
    )


async def translate(run: StageRun, index: int, named: dict[str, Any] | None = None) -> Any:
    await run.send("features", features_at(index, OPEN if named is None else named))
    return run.messages("servo_commands")[-1]


async def test_commands_are_stamped_for_the_controller_s_freshness_checks() -> None:
    async with StageRun(
        lambda ctx: serve_translator(ctx, Translator(LIMITED)), service="translator"
    ) as run:
        first = await translate(run, 0)
        await run.advance(0.5)
        second = await translate(run, 1)
    assert first.sender == second.sender and first.sender.startswith(run.ctx.instance + "/")
    assert (first.sender_seq, second.sender_seq) == (1, 2)
    assert second.sent_ns - first.sent_ns == 500_000_000  # the clock's wall time
    assert first.sender_host == clock_host() and first.move == "command"


async def test_a_translator_starts_from_where_the_controller_reports_the_servos() -> None:
    async with StageRun(
        lambda ctx: serve_translator(ctx, Translator(LIMITED)), service="translator"
    ) as run:
        await run.send("servo_state", state("report", jaw=1900.0, brow=1100.0))
        first = await translate(run, 0)
        second = await translate(run, 1)
    assert first.positions == {"jaw": 1900.0, "brow": 1100.0}
    assert second.positions["jaw"] == pytest.approx(1900.0 + 3000 * DT, abs=1e-3)


async def test_with_no_report_yet_it_starts_from_neutral_and_takes_the_first_report() -> None:
    async with StageRun(
        lambda ctx: serve_translator(ctx, Translator(LIMITED)), service="translator"
    ) as run:
        first = await translate(run, 0, {})
        assert first.positions == {"jaw": 1500.0, "brow": 1500.0}
        await run.send("servo_state", state("report", jaw=1300.0, brow=1500.0))
        after = await translate(run, 1, {})
    assert after.positions == {"jaw": 1300.0, "brow": 1500.0}


async def test_it_resumes_after_the_controller_moved_on_its_own_but_not_while_it_follows() -> None:
    async with StageRun(
        lambda ctx: serve_translator(ctx, Translator(LIMITED)), service="translator"
    ) as run:
        await translate(run, 0)
        moving = await translate(run, 1)
        await run.send("servo_state", state("command", jaw=1234.0, brow=1234.0))
        await run.send("servo_state", state("catch-up", jaw=1234.0, brow=1234.0))
        following = await translate(run, 2)
        assert following.positions["jaw"] > moving.positions["jaw"]  # no resume: it went on
        for move in ("start", "return", "stop", "report"):
            await run.send("servo_state", state(move, jaw=1111.0, brow=1222.0))
            resumed = await translate(run, 3)
            assert resumed.positions == {"jaw": 1111.0, "brow": 1222.0}, move
            await run.send("servo_state", state(move, jaw=1600.0, brow=1600.0))
            assert (await translate(run, 4)).positions == {"jaw": 1600.0, "brow": 1600.0}


async def test_reports_for_another_profile_or_undecodable_are_ignored() -> None:
    async with StageRun(
        lambda ctx: serve_translator(ctx, Translator(LIMITED)), service="translator"
    ) as run:
        other = msgspec.structs.replace(state("report", jaw=1100.0, brow=1100.0), profile="other")
        await run.send("servo_state", other)
        await run.send("servo_state", b"\x93garbage")
        first = await translate(run, 0, {})
    assert first.positions == {"jaw": 1500.0, "brow": 1500.0}


# --- the pure resume rule ----------------------------------------------------------------------


def test_resuming_translator_resumes_once_then_only_after_the_controller_moved_on_its_own() -> None:
    from facesynth.services.translator.resume import ResumingTranslator

    core = ResumingTranslator(Translator(LIMITED), sender="t/1", host="h")
    first = core.translate(features_at(0, OPEN), now_ns=5)
    assert core.resumed == "neutral" and first.positions == {"jaw": 1500.0, "brow": 1500.0}
    assert (first.sender, first.sender_seq, first.sent_ns, first.sender_host) == ("t/1", 1, 5, "h")
    core.watch.see(state("command", jaw=1500.0))  # following: nothing to resume from
    second = core.translate(features_at(1, OPEN), now_ns=6)
    assert core.resumed is None and second.sender_seq == 2
    core.watch.see(state("return", jaw=1600.0))  # the controller went back on its own
    core.translate(features_at(2, OPEN), now_ns=7)
    assert core.resumed == "reported"
