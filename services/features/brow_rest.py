"""The brows' part of a measured neutral, when the brows were not at rest over the first second.

F takes the performer's neutral from the first second with a face (``core.FeatureProcessor``).
When that second is not a neutral face, everything later is read against the wrong rest: the
bundled video opens on a sad face with the inner brows raised (the tracker's ``browInnerUp``
about 0.35 there, 0.01-0.03 in the laugh that follows), so the laugh's resting brows read as
lowered and the face frowned at it. With the ``full`` tracker model the blendshapes say whether
the brows were at rest: when the median of a brow blendshape over the neutral second is above
:data:`REST_SCORE`, the brows' part of the neutral (their named features and blendshapes, the
brow points' nose distances and eye-frame positions) is taken again from the first
``seconds`` of media time in which every brow blendshape stays at rest, frame after frame; until
then the brow features hold at 0 (neutral). The rest of the neutral, and a calibration's or a
restored neutral, are never changed.

The brow blendshapes only tell the brows' rest for certain while the eyes are open
(``eyeBlink*`` at most :data:`OPEN_EYES_SCORE`): with the eyes squeezed shut they miss a knitted
brow. The bundled video cries with the eyes shut from frame 25 to about 140, brows visibly drawn
down and together, while ``browDown*`` reads at most 0.16 there; a brows' neutral taken from
those frames made the laugh's relaxed brows read as a frown on paper16 (median -1.00 of the left
and middle eyebrows' travel). So a second of resting brows with the eyes shut (or a neutral
second like it) is a provisional rest: the brows follow it (they are no longer held) while the
search goes on for a second of resting brows with the eyes open, which replaces it and ends the
search (on the bundled video: provisional from frames 25-48, final from 215-238). Frames with
the eyes closed neither count toward that final second nor start it again.

"At rest" by :data:`REST_SCORE` is a typical face's rest, not every performer's: a real neutral
face can read ``browInnerUp`` 0.43 and ``browOuterUpLeft`` 0.25 at rest, and that second never
comes. So the search is bounded: after :data:`GIVE_UP_S` of media time it ends with the
quietest second it saw with the eyes open (the lowest level this performer's brows held for a
second: the largest of the brow blendshapes' medians), or, with no such second, with the
neutral's own brows. Each outcome is told to F's log (:meth:`BrowRest.waiting_for`,
:attr:`Found.quietest`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Final, Literal

import numpy as np

from facesynth.runtime import blendshapes
from facesynth.services.features.neutral import NeutralWindow, Sample

#: The tracker's brow blendshapes.
BROW_SHAPES: Final = (
    "browDownLeft",
    "browDownRight",
    "browInnerUp",
    "browOuterUpLeft",
    "browOuterUpRight",
)
#: A brow blendshape at most this strong counts as at rest (laughing brows: at most 0.2 on the
#: bundled video; its sad opening second: browInnerUp 0.29-0.43, browOuterUp up to 0.55).
REST_SCORE: Final = 0.2
#: The eyes count as open (and the brow blendshapes as telling) while both ``eyeBlink*`` scores
#: are at most this (the bundled video: 0.02-0.47 with the eyes open in the laugh, 0.57-0.91 for
#: the right and left eye while crying with the eyes shut).
OPEN_EYES_SCORE: Final = 0.5
#: Media seconds the search waits for a second at rest before it takes this performer's
#: quietest second as the rest (the bundled video finds its final rest about 8 s after its
#: neutral second).
GIVE_UP_S: Final = 12.0
#: The iBUG 68 brow points (17-21 right, 22-26 left).
BROW_POINTS: Final = slice(17, 27)
#: The named features read from the brows: re-based with them, held at 0 while pending.
BROW_NAMED: Final = frozenset(
    {
        f"{stem}_{side}"
        for stem in ("brow_raise_inner", "brow_raise_outer", "brow_lower")
        for side in ("right", "left")
    }
    | set(BROW_SHAPES)
)
_INDEX: Final = [blendshapes.INDEX[name] for name in BROW_SHAPES]
_EYES: Final = [blendshapes.INDEX[name] for name in ("eyeBlinkLeft", "eyeBlinkRight")]


def eyes_open(scores: np.ndarray) -> bool:
    """Whether both eyes of one frame's 52 scores are open (its brow blendshapes telling)."""
    return float(np.max(scores[_EYES])) <= OPEN_EYES_SCORE


def brows_at_rest(scores: np.ndarray) -> bool:
    """Whether every brow blendshape of one frame's 52 scores is at rest (eyes not looked at)."""
    return float(np.max(scores[_INDEX])) <= REST_SCORE


#: What a neutral's frames say of the brows: at rest with the eyes open, at rest by the
#: blendshapes but with the eyes shut (a provisional rest), moved; None: no blendshapes.
WindowRest = Literal["rest", "shut", "moved"]


def brow_level(samples: Sequence[Sample]) -> float:
    """How far from rest a second's brows held: the largest of the brow blendshapes' medians
    (0 with the brows relaxed, 1 fully moved); ``samples`` carry blendshapes."""
    scores = np.stack([s.blendshapes for s in samples if s.blendshapes is not None])
    return float(np.max(np.median(scores[:, _INDEX], axis=0)))


def window_at_rest(samples: Sequence[Sample]) -> WindowRest | None:
    """Whether the brows were at rest over a neutral's frames (per-shape medians), and the eyes
    open (median ``eyeBlink*``); None when the frames carry no blendshapes (nothing to tell)."""
    scores = [s.blendshapes for s in samples if s.blendshapes is not None]
    if not scores:
        return None
    medians = np.median(np.stack(scores), axis=0)
    if not brows_at_rest(medians):
        return "moved"
    return "rest" if eyes_open(medians) else "shut"


@dataclass(frozen=True)
class Found:
    """A second of resting brows: its frames, and whether it is final (eyes open).

    ``quietest``: the search gave up waiting for a second at rest and took the quietest second
    it saw (``samples`` empty: it saw none with the eyes open, and the neutral's own brows
    stay); ``level`` is that second's :func:`brow_level`.
    """

    samples: list[Sample]
    final: bool
    quietest: bool = False
    level: float = 0.0

    def note(self, t_media_ns: int) -> str:
        """F's log line for this outcome of the search, found at ``t_media_ns``."""
        at = f"at {t_media_ns / 1e9:.1f} s"
        if not self.quietest:
            kind = "a second of resting brows" if self.final else "a provisional rest (eyes shut)"
            return f"brows: {kind} found {at}; the brow features follow it"
        if not self.samples:
            return (
                f"brows: no second at rest and none with the eyes open {at}: the brows now "
                "follow the neutral's own second"
            )
        return (
            f"brows: no second at rest by {at}; this performer's quietest second (brow "
            f"blendshapes up to {self.level:.2f}) is taken as their rest"
        )


class BrowRest:
    """Looks for the first ``seconds`` of media time in which the brows stay at rest with the
    eyes open; meanwhile, for a provisional rest (resting brows, eyes shut)."""

    def __init__(
        self, seconds: float, *, provisional: bool = False, give_up_s: float = GIVE_UP_S
    ) -> None:
        """``provisional``: a provisional rest is known already (the neutral's own second);
        ``give_up_s``: media seconds before the quietest second seen is taken as the rest."""
        self.seconds = seconds
        self.give_up_ns = int(give_up_s * 1e9)
        self.start_ns: int | None = None
        #: The quietest second with the eyes open seen so far, and its level.
        self.quietest: list[Sample] = []
        self.quietest_level = float("inf")
        self._open: NeutralWindow[Sample] = NeutralWindow(seconds)
        #: Whether the brows have a rest to follow (provisional or final).
        self.known = provisional
        #: Whether the final rest was found (the search is over).
        self.done = False
        self.window: NeutralWindow[Sample] = NeutralWindow(seconds)
        self._any_eyes: NeutralWindow[Sample] = NeutralWindow(seconds)

    def add(self, t_media_ns: int, sample: Sample) -> Found | None:
        """Add a face frame; the frames of a rest once they span ``seconds``: the first
        provisional one (if none is known), then the final one (and nothing after it).

        A frame whose brows move (or without blendshapes) starts both searches again; a frame
        with the eyes closed (a blink, or eyes squeezed shut) counts only toward a provisional
        rest and neither counts toward the final one nor starts it again.
        """
        scores = sample.blendshapes
        if self.done:
            return None
        if self.start_ns is None:
            self.start_ns = t_media_ns
        self._watch_quietest(t_media_ns, sample)
        if t_media_ns - self.start_ns >= self.give_up_ns:
            self.known = self.done = True
            level = self.quietest_level if self.quietest else 0.0
            return Found(self.quietest, final=True, quietest=True, level=level)
        if scores is None or not brows_at_rest(scores):
            self.window = NeutralWindow(self.seconds)
            self._any_eyes = NeutralWindow(self.seconds)
            return None
        if eyes_open(scores) and self.window.add(t_media_ns, sample):
            self.known = self.done = True
            return Found(self.window.samples, final=True)
        if not self.known and self._any_eyes.add(t_media_ns, sample):
            self.known = True
            return Found(self._any_eyes.samples, final=False)
        return None

    def _watch_quietest(self, t_media_ns: int, sample: Sample) -> None:
        """Keep the quietest whole second of eyes-open frames (seconds back to back)."""
        scores = sample.blendshapes
        if scores is None:
            self._open = NeutralWindow(self.seconds)
            return
        if not eyes_open(scores):
            return
        if self._open.add(t_media_ns, sample):
            level = brow_level(self._open.samples)
            if level < self.quietest_level:
                self.quietest, self.quietest_level = self._open.samples, level
            self._open = NeutralWindow(self.seconds)
            self._open.add(t_media_ns, sample)

    def waiting_for(self) -> str:
        """What the search waits for, in words (F's log)."""
        kind = "a provisional rest is followed meanwhile" if self.known else "held at neutral"
        return (
            f"brows: waiting for a {self.seconds:g} s with every brow blendshape at most "
            f"{REST_SCORE:g} and the eyes open ({kind}); after {self.give_up_ns / 1e9:g} s the "
            "quietest second seen is taken as this performer's rest"
        )
