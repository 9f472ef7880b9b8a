"""A translator of one robot among several reads the performer's shared features and publishes
on its robot's command key, so robots of different profiles share one performer."""

from __future__ import annotations

from translator_fixtures import features_at

from facesynth.runtime.clock import FakeClock
from facesynth.runtime.profiles import load_profile
from facesynth.runtime.testing import StageRun
from facesynth.services.translator.core import Translator
from facesynth.services.translator.service import serve_translator


async def test_commands_go_to_the_robots_own_key() -> None:
    translator = Translator(load_profile("head16"))
    async with StageRun(
        lambda ctx: serve_translator(ctx, translator),
        service="translator",
        robot="head_b",
        clock=FakeClock(),
    ) as run:
        await run.send("features", features_at(0, {"jaw_open": 0.5}))
        [published] = run.on("servo_commands")
        assert published.key == f"facesynth/{run.rig}/servo_commands/head_b"
        assert published.message.profile == "head16"
        assert published.message.seq == 0
