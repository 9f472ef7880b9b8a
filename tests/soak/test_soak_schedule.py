"""The soak's round-robin of faults (tools/soak/schedule.py)."""

from __future__ import annotations

import itertools

import pytest

from tools.soak.schedule import ALL_KINDS, KILL_TARGETS, KINDS, rounds


def test_kinds_take_turns_and_each_kind_its_targets() -> None:
    first = list(itertools.islice(rounds(), 4 * len(KILL_TARGETS)))
    assert [kind for kind, _ in first[:4]] == list(KINDS)
    kills = [target for kind, target in first if kind == "kill"]
    assert kills == list(KILL_TARGETS)  # every stage and the router, once each
    assert "router" in kills
    assert {target for kind, target in first if kind == "stall"} == {"points"}


def test_link_cuts_take_their_turn_last() -> None:
    first = list(itertools.islice(rounds(ALL_KINDS), 10))
    assert first[4] == ("cut", "board") and first[9] == ("cut", "board")
    assert [kind for kind, _ in first[:5]] == [*KINDS, "cut"]


def test_chosen_kinds_and_targets() -> None:
    chosen = rounds(["kill", "flood"], {"kill": ["sensor", "points"], "flood": ["stats"]})
    assert list(itertools.islice(chosen, 5)) == [
        ("kill", "sensor"),
        ("flood", "stats"),
        ("kill", "points"),
        ("flood", "stats"),
        ("kill", "sensor"),
    ]


def test_a_kind_without_targets_is_refused() -> None:
    with pytest.raises(ValueError, match="no targets for fault kind 'unplug'"):
        next(rounds(["unplug"]))
    with pytest.raises(ValueError, match="'kill'"):
        next(rounds(["kill"], {"kill": []}))
