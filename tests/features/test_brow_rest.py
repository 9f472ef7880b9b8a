"""The brows' rest search (services.features.brow_rest) on hand-made blendshape scores."""

from __future__ import annotations

import numpy as np

from facesynth.runtime import blendshapes
from services.features.brow_rest import BrowRest, brows_at_rest, eyes_open, window_at_rest
from services.features.neutral import Sample

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


def test_a_window_with_the_eyes_shut_tells_no_rest() -> None:
    """Crying with the eyes squeezed shut: brow blendshapes at rest, brows not trusted."""
    assert window_at_rest([_sample(SHUT)] * 10) is False
    assert window_at_rest([_sample(REST)] * 10) is True
    assert window_at_rest([_sample(RAISED)] * 10) is False
    assert window_at_rest([_sample(None)] * 10) is None


def test_closed_eyes_neither_count_nor_restart_the_search() -> None:
    search = BrowRest(1.0)
    t = 0
    for _ in range(5):
        assert search.add(t, _sample(REST)) is None
        t += STEP
    for _ in range(30):  # three seconds of closed eyes: left out
        assert search.add(t, _sample(SHUT)) is None
        t += STEP
    assert search.add(t, _sample(REST)) is not None  # the second since the first rest is over
    assert all(s.blendshapes is REST for s in search.window.samples)


def test_moving_brows_restart_the_search() -> None:
    search = BrowRest(1.0)
    t = 0
    for scores in [REST] * 5 + [RAISED] + [REST] * 10:
        assert search.add(t, _sample(scores)) is None
        t += STEP
    found = search.add(t, _sample(REST))
    assert found is not None and len(found) == 10  # the rest frames after the raise
