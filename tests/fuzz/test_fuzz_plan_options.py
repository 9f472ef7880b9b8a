"""Fuzz the plan options a babbling session keeps (facesynth.app.learn.plan_options): any text in
a session's ``learn_*`` metadata fields is read as whole numbers or refused in one line
(PlanError), and what is read either makes a plan on resume (the same options again: the kept
values round-trip through the metadata) or is refused in one line; nothing else escapes."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest
from fuzzing import FUZZ, TIMEOUT, check_tally, outcome
from hypothesis import given
from hypothesis import strategies as st

from facesynth.app.learn.plan import PlanError
from facesynth.app.learn.plan_options import FIELD_PREFIX, choose, shaping, stored

pytestmark = [pytest.mark.fuzz, TIMEOUT]

NONE_GIVEN = argparse.Namespace(**{name: None for name in shaping("adaptive")})
values = st.one_of(
    st.integers(0, 2000).map(str),
    st.integers(-5, 2**70).map(str),
    st.sampled_from(["", " 3", "3 ", "+3", "-1", "3.0", "1e3", "0x10", "٣", "1_000", "007"]),
    st.text(max_size=8),
)
fields = st.dictionaries(st.sampled_from(sorted(shaping("adaptive"))), values, max_size=6)


def test_kept_plan_options_read_back_or_are_one_error_line() -> None:
    target = "learn.plan_options.stored"

    @FUZZ
    @given(st.sampled_from(["fixed", "adaptive"]), fields, st.integers(0, 2**31))
    def case(kind: str, kept: dict[str, str], seed: int) -> None:
        meta = {FIELD_PREFIX + name: text for name, text in kept.items()}
        options = outcome(target, lambda: stored(meta, kind, Path("s.mcap")), PlanError)
        if options is None:
            return
        assert set(options) <= set(shaping(kind))
        assert all(isinstance(v, int) and v >= 0 for v in options.values())
        choice = outcome(
            target + " (resume)",
            lambda: choose(NONE_GIVEN, kind, seed, options, Path("s.mcap")),
            PlanError,
        )
        if choice is not None:
            again = stored(choice.metadata(), kind, Path("s.mcap"))
            assert again == dict(choice.values) and options.items() <= again.items()

    case()
    check_tally(target, "valid", "refused")
    check_tally(target + " (resume)", "valid", "refused", every_case=False)
