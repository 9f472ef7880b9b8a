"""Fuzz the names of generated heads (``seed:N``, ``generated:N``; facesynth.app.simhead.generated)
and the heads they give.

Any text is parsed by :func:`generated_seed`: ``None`` (not a generated head's name), a seed, or
a one-line :class:`HeadError`; a text with a generated head's prefix (valid seeds, near misses:
signs, blanks, decimals, digits beyond 2**32 - 1, other characters) loads through
:func:`load_head` into a head that passes every check of a head file and is put through the
moves of the head-file target (``exercise``: every pulse, position, output and activation
finite and in range), or into the same error.
"""

from __future__ import annotations

from typing import Any

import pytest
from fuzzing import FUZZ, TIMEOUT, check_tally, outcome
from hypothesis import given
from hypothesis import strategies as st
from test_fuzz_simhead import MOVES, exercise

from facesynth.app.simhead.config import HeadError
from facesynth.app.simhead.generated import MAX_SEED, PREFIXES, generated_seed
from facesynth.app.simhead.heads import load_head

pytestmark = [pytest.mark.fuzz, TIMEOUT]

tails = st.one_of(
    st.integers(0, MAX_SEED).map(str),
    st.integers(0, MAX_SEED).map(str),
    st.integers(-(2**40), 2**40).map(str),
    st.sampled_from(["", " 1", "1 ", "+1", "-0", "1.0", "1e3", "0x10", "٣", "1_000", "\n1"]),
    st.text(max_size=12),
)
names = st.one_of(
    st.tuples(st.sampled_from(PREFIXES), tails).map("".join),
    st.tuples(st.sampled_from(PREFIXES), tails).map("".join),
    st.text(max_size=24),
)


def test_generated_head_names_give_a_head_or_one_error_line() -> None:
    target = "simhead.generated_seed + load_head"

    @FUZZ
    @given(names, MOVES)
    def case(name: str, moves: list[Any]) -> None:
        seed = outcome(target, lambda: generated_seed(name), HeadError)
        if not name.startswith(PREFIXES):
            assert seed is None
            return
        config = outcome(target + " (load)", lambda: load_head(name), HeadError)
        assert (config is None) == (seed is None)
        if config is not None:
            assert seed is not None and config.name == f"seed:{seed}"
            assert 0 <= seed <= MAX_SEED and len(config.actuators) == 16
            exercise(config, moves)

    case()
    check_tally(target, "valid", "refused")
    check_tally(target + " (load)", "valid", "refused", every_case=False)
