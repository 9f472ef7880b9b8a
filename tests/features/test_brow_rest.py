"""The brows' rest search (facesynth.services.features.brow_rest) on hand-made blendshape scores."""

from __future__ import annotations

import numpy as np
import pytest

from facesynth.runtime import blendshapes
from facesynth.services.features.brow_rest import (
    BrowRest,
    Found,
    brows_at_rest,
    eyes_open,
    window_at_rest,
)
from facesynth.services.features.neutral import Sample

SECOND = 1_000_000_000
STEP = SECOND // 10


def _scores(**values: float) -> np.ndarray:
    scores = np.zeros(blendshapes.COUNT)
    for name, value in values.items():
        scores[blendshapes.INDEX[name]] = value
    return scores


def _sample(scores: np.ndarray | None) -> Sample:
    return Sample(np.zeros((68, 2)), np.zeros((68, 2)), blendshapes=scores)


REST = _scores()
RAISED = _scores(browInnerUp=0.4)
SHUT = _scores(eyeBlinkLeft=0.8, eyeBlinkRight=0.7)


def test_a_frame_is_at_rest_by_its_brows_and_open_by_its_eyes() -> None:
    assert brows_at_rest(REST) and eyes_open(REST)
    assert not brows_at_rest(RAISED)
    assert brows_at_rest(SHUT) and not eyes_open(SHUT)
    assert not eyes_open(_scores(eyeBlinkRight=0.6))


def test_a_window_with_the_eyes_shut_tells_a_provisional_rest() -> None:
    """Crying with the eyes squeezed shut: brow blendshapes at rest, brows not trusted."""
    assert window_at_rest([_sample(SHUT)] * 10) == "shut"
    assert window_at_rest([_sample(REST)] * 10) == "rest"
    assert window_at_rest([_sample(RAISED)] * 10) == "moved"
    assert window_at_rest([_sample(None)] * 10) is None


def _feed(search: BrowRest, frames: list[np.ndarray | None], t: int = 0) -> list[tuple[int, Found]]:
    found = []
    for i, scores in enumerate(frames):
        result = search.add(t + i * STEP, _sample(scores))
        if result is not None:
            found.append((i, result))
    return found


def test_resting_brows_with_the_eyes_shut_are_a_provisional_rest_then_open_ones_final() -> None:
    search = BrowRest(1.0)
    found = _feed(search, [SHUT] * 15 + [REST] * 15)
    assert [(i, f.final) for i, f in found] == [(10, False), (25, True)]
    assert all(s.blendshapes is SHUT for s in found[0][1].samples)
    assert all(s.blendshapes is REST for s in found[1][1].samples)
    assert search.known


def test_a_known_provisional_rest_is_not_searched_again() -> None:
    search = BrowRest(1.0, provisional=True)
    assert search.known
    assert _feed(search, [SHUT] * 30) == []
    assert [(i, f.final) for i, f in _feed(search, [REST] * 11, 30 * STEP)] == [(10, True)]


def test_closed_eyes_neither_count_nor_restart_the_final_search() -> None:
    search = BrowRest(1.0, provisional=True)
    found = _feed(search, [REST] * 5 + [SHUT] * 30 + [REST])
    assert [(i, f.final) for i, f in found] == [(35, True)]  # a second since the first rest
    assert all(s.blendshapes is REST for s in found[0][1].samples)


def test_moving_brows_restart_the_search() -> None:
    search = BrowRest(1.0)
    found = _feed(search, [REST] * 5 + [RAISED] + [REST] * 11)
    assert [(i, f.final) for i, f in found] == [(16, True)]
    assert len(found[0][1].samples) == 10  # the rest frames after the raise
    assert _feed(BrowRest(1.0), [SHUT] * 5 + [None] + [SHUT] * 9) == []  # no scores: moved


#: A performer whose brows read high at rest (a held-out clip's neutral face: browInnerUp 0.43,
#: browOuterUpLeft 0.25), never at most REST_SCORE.
HIGH_REST = _scores(browInnerUp=0.43, browOuterUpLeft=0.25)
HIGH_RAISED = _scores(browInnerUp=0.8, browOuterUpLeft=0.7, browOuterUpRight=0.6)


def test_a_search_that_finds_no_rest_takes_the_performers_quietest_second() -> None:
    search = BrowRest(1.0, give_up_s=5.0)
    frames = ([HIGH_RAISED] * 10 + [HIGH_REST] * 15 + [HIGH_RAISED] * 10) * 2
    found = _feed(search, frames)
    assert len(found) == 1, found
    at, result = found[0]
    assert at == 50  # 5 s of media time: the search is bounded
    assert result.final and result.quietest and result.level == pytest.approx(0.43)
    assert all(s.blendshapes is HIGH_REST for s in result.samples)
    assert search.done and search.known
    assert "quietest second" in result.note(at * STEP) and "0.43" in result.note(at * STEP)


def test_a_search_with_the_eyes_always_shut_ends_with_the_neutrals_own_brows() -> None:
    search = BrowRest(1.0, give_up_s=3.0)
    found = _feed(search, [_scores(browInnerUp=0.5, eyeBlinkLeft=0.9, eyeBlinkRight=0.9)] * 40)
    assert [(i, f.final, f.quietest, f.samples) for i, f in found] == [(30, True, True, [])]
    assert "neutral's own second" in found[0][1].note(30 * STEP)


def test_a_rest_found_in_time_is_not_the_fallback() -> None:
    search = BrowRest(1.0, give_up_s=5.0)
    found = _feed(search, [HIGH_RAISED] * 10 + [REST] * 15)
    assert [(i, f.final, f.quietest) for i, f in found] == [(20, True, False)]
    assert "waiting for a 1 s" in search.waiting_for()
