"""Fuzz the rig console: its page messages, its ``--page`` address, and random edits of a
profile from the page (jogs, limits from where a servo stands or typed, names, reversal):
every edit is made or refused with one line, the jog targets never leave the limits C
enforces, and the draft always saves as TOML that reads back identically."""

from __future__ import annotations

import math

import pytest
from fuzzing import FUZZ, TIMEOUT, check_tally, outcome
from hypothesis import given
from hypothesis import strategies as st

from facesynth.app.console import protocol as p
from facesynth.app.console.command import parse_page
from facesynth.app.console.profile_file import profile_toml
from facesynth.app.console.rig import ConsoleError, ConsoleRig
from facesynth.app.wiring import OptionError
from facesynth.runtime.profiles import load_profile, parse_profile

pytestmark = [pytest.mark.fuzz, TIMEOUT]

PIECES = ['{"type": "jog", "servo": ', '{"type": "limit", "servo": ', '"which": "min"', "1500",
          "1e999", "NaN", "-0", "true", "null", '"x"', "}", "{", ", ", '"us": ', "99", "-1",
          '"name": "a b"', '"token": "t"', "\ud800", "\x00", "[]", '"hello"',
          '{"type": "save"}']  # fmt: skip


def test_console_page_messages_parse_or_raise_message_error() -> None:
    target = "console protocol.parse (page message)"

    @FUZZ
    @given(
        st.one_of(
            st.lists(st.sampled_from(PIECES), max_size=8).map("".join),
            st.builds(
                '{{"type": "{}", "{}": {}}}'.format,
                st.sampled_from(p.TYPES),
                st.sampled_from(["servo", "us", "which", "name", "reversed", "token", "t"]),
                st.sampled_from(["1.5", "true", "1e999", "NaN", "null", '"min"', "-3", "0"]),
            ),
            st.builds(
                '{{"type": "{}", "servo": {}, "{}": {}}}'.format,
                st.sampled_from(["jog", "limit", "reverse", "rename"]),
                st.sampled_from(["0", "15", "-1", "1.0", '"0"']),
                st.sampled_from(["us", "which", "reversed", "name"]),
                st.sampled_from(["1500", "1e999", '"min"', "true", '"jaw"', "null"]),
            ),
            st.text(max_size=80),
            st.text(min_size=p.MAX_MESSAGE - 4, max_size=p.MAX_MESSAGE + 8),
        )
    )
    def case(text: str) -> None:
        outcome(target, lambda: p.parse(text), p.MessageError)

    case()
    check_tally(target, "valid", "refused")


def test_console_page_addresses_parse_or_raise_option_error() -> None:
    target = "console parse_page (--page)"
    pieces = ("localhost", "[::1]", ":", "8095", "65536", "-1", "²", "٣", "0", "", " ", "]")

    @FUZZ
    @given(st.one_of(st.lists(st.sampled_from(pieces), max_size=6).map("".join), st.text()))
    def case(text: str) -> None:
        outcome(target, lambda: parse_page(text), OptionError)

    case()
    check_tally(target, "valid", "refused")


PROFILE = load_profile("head16_hardware")
SERVO = st.one_of(st.integers(-2, len(PROFILE.servos) + 1), st.sampled_from([True, 1.0, "0"]))
US = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(400, 2600),
    st.sampled_from([1000.0, 1500.0, 2000.0, -0.0]),
)
EDIT = st.one_of(
    st.tuples(st.just("jog"), SERVO, US),
    st.tuples(st.just("report"), SERVO, US),
    st.tuples(st.just("limit"), SERVO, st.sampled_from(["min", "neutral", "max", "top"]),
              st.one_of(st.none(), US)),
    st.tuples(st.just("rename"), SERVO, st.sampled_from(["jaw", "a b", "", "x" * 41, "ok_1"])),
    st.tuples(st.just("reverse"), SERVO, st.booleans()),
    st.tuples(st.sampled_from(["centre", "neutral", "stop", "release"])),
)  # fmt: skip


def _apply(rig: ConsoleRig, edit: tuple[object, ...]) -> None:
    kind, *rest = edit
    if kind == "report":
        index, us = rest
        if isinstance(index, int) and 0 <= index < len(PROFILE.servos) and math.isfinite(us):
            spec = rig.active.servos[index]
            rig.report(rig.active.name, {spec.name: spec.clamp(float(us))})  # as C reports
        return
    actions = {
        "jog": lambda: rig.jog(*rest),
        "limit": lambda: rig.set_limit(*rest),
        "rename": lambda: rig.rename(*rest),
        "reverse": lambda: rig.reverse(*rest),
        "centre": rig.centre_all,
        "neutral": rig.neutral_all,
        "stop": rig.stop_all,
        "release": rig.release,
    }
    actions[str(kind)]()  # type: ignore[no-untyped-call]


def test_console_edits_keep_the_limits_and_save_identically() -> None:
    target = "console ConsoleRig edits (from the page)"

    @FUZZ
    @given(st.lists(EDIT, max_size=12))
    def case(edits: list[tuple[object, ...]]) -> None:
        rig = ConsoleRig(PROFILE)
        for edit in edits:
            outcome(target, lambda edit=edit: _apply(rig, edit), ConsoleError)
            for index, target_us in enumerate(rig.targets):
                active, draft = rig.active.servos[index], rig.draft.servos[index]
                assert active.min_us <= target_us <= active.max_us
                assert draft.min_us <= target_us <= draft.max_us or (
                    target_us == active.neutral_us  # draft and active ranges do not meet
                )
        assert parse_profile(profile_toml(rig.draft)) == rig.draft

    case()
    check_tally(target, "valid", "refused", every_case=False)
