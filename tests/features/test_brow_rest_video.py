"""The demo face does not frown at a laugh (issue 20): the brows' neutral on the sample video.

The bundled video opens on a sad face with the inner brows raised (the tracker's browInnerUp
0.29-0.43 over the first second), which F used to take as the neutral: every later resting brow
then read as lowered, and in the laugh the virtual face's brows sat at their minimum.

Measured over the frames after the first second where the performer smiles or laughs (mean
mouthSmile >= 0.5) and the tracker's own brow blendshapes say the brows are at rest (browDown*,
browInnerUp, browOuterUp* all <= 0.2): 163 frames, 95 of them in the laugh (from frame 230).
Shares of travel from neutral, right / left, before -> after the brows' neutral was taken from
a second of resting brows (services.features.brow_rest; ``python tools/brows_at_laugh.py``):

* virtual_bs brows (blendshape brows): within +-0.25 of neutral 12 % / 40 % -> 100 % / 99 %;
* virtual brows (geometric): median -0.76 / -0.97 -> +0.00 / -0.35 (at -0.5 or lower: 72 % /
  99 % -> 13 % / 31 %);
* head16 brows (right, left, middle): median -0.71 / -0.92 / -1.00 -> +0.00 / -0.30 / -0.23.

That second of resting brows was frames 25-48: crying with the eyes squeezed shut, the brows
visibly drawn down and together while the brow blendshapes read at most 0.05 (they miss a
knitted brow behind closed eyes). paper16's left and middle eyebrows (2D nose distances) then
read the laugh's relaxed brows as lowered: median -1.00 / -1.00 over the laugh's 95 frames, 100 %
/ 88 % of them at -0.5 or lower. Now a resting second with the eyes shut is only a provisional
rest (the brows follow it, so they keep moving through the crying and the look up), and the
first resting second with the eyes open, frames 215-238 (just before the laugh), replaces it.
And paper16's nose distances are taken with the head's yaw undone
(``services.features.core.paper_frame``: the laugh is turned 11-22 degrees to her left, which
in 2D shortened the left brow's distances 0.008 inter-ocular units per degree). Over the laugh,
right / left / middle, before -> after:

* paper16: median +0.22 / -1.00 / -1.00 -> -0.21 / +0.04 / -0.22; within +-0.25 57 % / 0 % /
  4 % -> 53 % / 71 % / 42 %; at -0.5 or lower 0 % / 100 % / 88 % -> 11 % / 11 % / 19 % (most of
  those in the laugh's first frames, 230-239, still read against the crying: its chin is 14
  degrees higher, which the 2D distances read as lowered brows). With the whole rotation taken
  out against the neutral mesh, in the neutral's eye-corner frame (issue 27,
  ``services.features.frontal``): median -0.07 / +0.18 / +0.00, within +-0.25 89 % / 77 % /
  100 %, none at -0.5 or lower;
* head16 (named features, unaffected by the yaw step): median -0.20 / -0.39 / -0.82 ->
  -0.64 / -0.18 / -0.49;
* virtual: median -0.25 / -0.44 -> -0.69 / -0.23 (the mesh-aligned brow heights read the
  laugh's right brow low against a neutral without a cheek raise: the stable vertices the head
  pose is fitted on include the eye corners and cheekbones, which a laugh lifts);
* virtual_bs: 100 % / 100 % within +-0.25, as before.
"""

from __future__ import annotations

import msgspec
import numpy as np
import pytest
from sample_points import track_sample

from facesynth.runtime import blendshapes
from facesynth.runtime.profiles import Profile, load_profile
from facesynth.schemas.messages import Points, ScoreSet
from facesynth.services.features.brow_rest import (
    BROW_SHAPES,
    GIVE_UP_S,
    OPEN_EYES_SCORE,
    REST_SCORE,
)
from facesynth.services.features.core import FeatureProcessor
from facesynth.services.features.point_sets import blendshape_scores
from facesynth.services.translator.core import Translator

#: A brow control this close to neutral (share of its travel) is in its neutral band.
BAND = 0.25


@pytest.fixture(scope="module")
def tracked() -> list[Points]:
    return track_sample("full")


def _smiling_with_resting_brows(tracked: list[Points]) -> np.ndarray:
    chosen = []
    for i, points in enumerate(tracked):
        scores = blendshape_scores(points)
        assert scores is not None

        def score(name: str, scores: np.ndarray = scores) -> float:
            return float(scores[blendshapes.INDEX[name]])

        smile = (score("mouthSmileLeft") + score("mouthSmileRight")) / 2
        rest = max(score(name) for name in BROW_SHAPES) <= REST_SCORE
        chosen.append(i >= 24 and smile >= 0.5 and rest)
    return np.asarray(chosen)


def _brow_travel(profile: Profile, tracked: list[Points]) -> dict[str, np.ndarray]:
    """Each brow servo's position as a share of its travel from neutral, per frame."""
    processor = FeatureProcessor(neutral_seconds=profile.neutral_seconds)
    translator = Translator(profile)
    positions = [translator.step(processor.process(points)) for points in tracked]
    out = {}
    for spec in profile.servos:
        if "brow" not in spec.name:
            continue
        values = np.array([p[spec.name] for p in positions]) - spec.neutral_us
        span = np.where(values >= 0, spec.max_us - spec.neutral_us, spec.neutral_us - spec.min_us)
        out[spec.name] = values / span
    return out


def test_the_opening_second_is_not_a_brow_neutral(tracked) -> None:
    """The premise: the first second's brows are raised, the laugh's at rest."""
    first = np.stack([blendshape_scores(p) for p in tracked[:24]])
    assert np.median(first[:, blendshapes.INDEX["browInnerUp"]]) > REST_SCORE
    assert _smiling_with_resting_brows(tracked)[230:].sum() >= 80


def test_blendshape_brows_stay_in_their_band_through_the_laugh(tracked) -> None:
    chosen = _smiling_with_resting_brows(tracked)
    for servo, travel in _brow_travel(load_profile("virtual_bs"), tracked).items():
        within = np.mean(np.abs(travel[chosen]) <= BAND)
        assert within >= 0.95, f"virtual_bs {servo}: {within:.0%} of the frames in the band"


@pytest.mark.parametrize("name", ["virtual", "head16"])
def test_geometric_brows_do_not_frown_at_the_laugh(tracked, name: str) -> None:
    chosen = _smiling_with_resting_brows(tracked)
    for servo, travel in _brow_travel(load_profile(name), tracked).items():
        assert np.median(travel[chosen]) > -BAND - 0.1, f"{name} {servo} reads a frown"
        assert np.mean(travel[chosen] <= -0.5) < 0.5, f"{name} {servo} at a frown"


#: The laugh: from this frame on (the smiles before it are crying with the eyes shut).
LAUGH = 230


def test_the_crying_frames_are_no_brow_neutral(tracked) -> None:
    """The premise of the eyes-open rule: the crying frames after the first second have the brow
    blendshapes at rest and the eyes shut (a provisional rest); the laugh has them at rest with
    the eyes open."""
    scores = np.stack([blendshape_scores(p) for p in tracked])
    brows = scores[:, [blendshapes.INDEX[name] for name in BROW_SHAPES]].max(axis=1)
    eyes = scores[:, [blendshapes.INDEX["eyeBlinkLeft"], blendshapes.INDEX["eyeBlinkRight"]]]
    crying = slice(25, 49)
    assert np.all(brows[crying] <= REST_SCORE)
    assert np.all(eyes[crying].max(axis=1) > OPEN_EYES_SCORE)
    laugh = _smiling_with_resting_brows(tracked)[LAUGH:]
    assert np.mean(eyes[LAUGH:][laugh].max(axis=1) <= OPEN_EYES_SCORE) > 0.95


def test_the_brows_neutral_is_taken_with_the_eyes_open(tracked) -> None:
    """The search ends on a second with the eyes open; the crying's is provisional."""
    processor = FeatureProcessor()
    taken = None
    for i, points in enumerate(tracked):
        pending = processor.brows is not None
        processor.process(points)
        if pending and processor.brows is None:
            taken = i
            break
    assert taken is not None and 200 <= taken <= LAUGH + 24, f"brows' neutral at frame {taken}"


def test_paper16_brows_stay_near_neutral_through_the_laugh(tracked) -> None:
    """The demo's bars (paper16: nose distances of the Table 1 brow groups), with the head's
    whole rotation taken out against the neutral mesh (issue 27; ``services.features.frontal``):
    right / left / middle within +-0.25 on 89 % / 77 % / 100 % of the laugh's frames, none at
    -0.5 or lower (the yaw alone undone: 53 % / 71 % / 42 %, and 11 % / 11 % / 19 %)."""
    laugh = _smiling_with_resting_brows(tracked)
    laugh[:LAUGH] = False
    for servo, travel in _brow_travel(load_profile("paper16"), tracked).items():
        t = travel[laugh]
        assert abs(np.median(t)) <= BAND, f"paper16 {servo}: median {np.median(t):+.2f}"
        assert np.mean(np.abs(t) <= BAND) >= 0.7, f"paper16 {servo} leaves its neutral band"
        assert np.mean(t <= -0.5) < 0.03, f"paper16 {servo} reads a frown"


def test_the_brows_hold_neutral_until_they_rest(tracked) -> None:
    """From the end of the sad second until a second of resting brows (here the crying's, a
    provisional rest), the brows hold 0; then they follow it while the search goes on."""
    processor = FeatureProcessor()
    outs = [processor.process(points) for points in tracked[:60]]
    for out in outs[24:48]:
        assert out.named["brow_lower_right"] == 0.0 and out.named["browInnerUp"] == 0.0
        assert out.deltas[17:27] == [0.0] * 10
    assert outs[30].named["jaw_open"] != 0.0  # the rest of the face moves meanwhile
    assert processor.brows is not None and processor.brows.known  # provisional: still looking
    assert all(out.named["brow_lower_right"] != 0.0 for out in outs[50:])
    assert all(out.deltas[17:27] != [0.0] * 10 for out in outs[50:])


def _with_high_resting_brows(points: Points) -> Points:
    """The frame as a performer whose brows read high at rest would give it: browInnerUp and
    browOuterUpLeft raised by a held-out clip's resting levels (0.43 and 0.25), capped at 1."""
    raised = blendshape_scores(points)
    assert raised is not None
    raised = raised.copy()
    raised[blendshapes.INDEX["browInnerUp"]] += 0.43
    raised[blendshapes.INDEX["browOuterUpLeft"]] += 0.25
    scores = [ScoreSet(scheme=blendshapes.BLENDSHAPES52, values=np.minimum(raised, 1.0).tolist())]
    return msgspec.structs.replace(points, scores=scores)


def test_brows_that_rest_high_are_not_held_for_the_whole_clip(tracked) -> None:
    """No second has every brow blendshape at most 0.2: the search gives up after GIVE_UP_S of
    media time, takes her quietest second, says so, and the brows follow her from then on (they
    were held at exactly 0 for the whole clip), reading her laugh's resting brows near neutral
    against her own rest."""
    processor = FeatureProcessor()
    outs, notes = [], []
    for points in tracked:
        outs.append(processor.process(_with_high_resting_brows(points)))
        notes += processor.notes
        processor.notes.clear()
    assert processor.brows is None, "the brows are still waiting at the end of the clip"
    assert any("waiting for" in note for note in notes), notes
    assert any("quietest second" in note for note in notes), notes
    fps = len(tracked) / ((tracked[-1].t_media_ns - tracked[0].t_media_ns) / 1e9)
    after = outs[int((1 + GIVE_UP_S) * fps) + 2 :]
    inner = np.array([out.named["browInnerUp"] for out in after])
    assert np.all(inner != 0.0), "the brows are still held after the search gave up"
    assert abs(float(np.median(inner))) <= BAND, "her resting brows read away from neutral"
