"""Payload limits: per key and per Zenoh session."""

from __future__ import annotations

import json

import pytest

from facesynth.runtime import keys, limits
from facesynth.runtime.bus.zenoh_bus import MESSAGE_LIMIT_PATH, ZenohOptions


@pytest.mark.parametrize("stage", keys.STAGES)
def test_every_stage_has_a_limit_above_the_stats_limit(stage: keys.Stage) -> None:
    assert limits.stage_limit(stage) > limits.STATS_LIMIT


@pytest.mark.parametrize(("service", "stage"), keys.CONSUMES.items())
def test_a_session_takes_its_input_and_servo_state_but_no_more(
    service: str, stage: keys.Stage | None
) -> None:
    size = limits.session_limit(stage)
    largest = max(limits.stage_limit(stage) if stage else 0, limits.stage_limit("servo_state"))
    assert size == largest + limits.MESSAGE_SLACK, service


def test_the_session_limit_reaches_zenoh_unless_the_user_set_one() -> None:
    options = ZenohOptions(mode="client").with_message_limit(123_456)
    assert json.loads(options.build().get_json(MESSAGE_LIMIT_PATH)) == 123_456
    mine = ZenohOptions(mode="client", overrides={MESSAGE_LIMIT_PATH: 999})
    assert json.loads(mine.with_message_limit(5).build().get_json(MESSAGE_LIMIT_PATH)) == 999
