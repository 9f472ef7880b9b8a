"""Feature processor F, service shell: ``…/points`` → ``…/features``.

With a :class:`StateKeeping` (no calibration), what F learns of the performer (the neutral, and
with ``auto_range`` the rolling neutral and ranges) is read at start from
``<state dir>/<rig>/<performer>.json`` and written back when it is learned, every
``SAVE_INTERVAL_S`` while it changes, and on the way out; each time is logged
(:mod:`facesynth.services.features.state`).
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass
from pathlib import Path

from facesynth.runtime.capture_age import DEFAULT_MAX_AGE_S
from facesynth.runtime.service import ServiceContext, serve_transform
from facesynth.schemas.messages import Features, Points
from facesynth.services.features.core import FeatureProcessor
from facesynth.services.features.state import (
    SAVE_INTERVAL_S,
    LearnedState,
    StateError,
    learned,
    load_state,
    restore,
    save_state,
    snapshot,
    state_path,
)


@dataclass
class StateKeeping:
    """Keep F's learned state for ``performer`` in ``state_dir`` (default: see the state
    module); ``relearn`` ignores what is kept and learns afresh (then overwrites it)."""

    performer: str = "default"
    state_dir: str | None = None
    relearn: bool = False


class _Keeper:
    """Reads, watches and writes one processor's learned state on behalf of the shell."""

    def __init__(self, ctx: ServiceContext, processor: FeatureProcessor, keeping: StateKeeping):
        self.ctx = ctx
        self.processor = processor
        self.performer = keeping.performer
        self.path: Path = state_path(keeping.state_dir, ctx.rig, keeping.performer)
        self.saved: LearnedState | None = None
        self._last_save_ns: int | None = None
        self._had_neutral = False
        if not keeping.relearn:
            self._restore()
        else:
            ctx.log.info("--relearn: learning the neutral of %s afresh", self.performer)
        self._had_neutral = learned(processor)

    def _restore(self) -> None:
        try:
            state = load_state(self.path)
            if state is None:
                self.ctx.log.info(
                    "no learned state for performer %s on rig %s yet: learning the neutral "
                    "from the first %.1f s with a face (kept in %s)",
                    self.performer,
                    self.ctx.rig,
                    self.processor.window.window_ns / 1e9,
                    self.path,
                )
                return
            restore(self.processor, state)
        except StateError as exc:
            self.ctx.log.warning("cannot use the learned state (%s): learning afresh", exc)
            return
        self.saved = state
        age_s = max(0.0, (self.ctx.clock.time_ns() - state.updated_ns) / 1e9)
        self.ctx.log.info(
            "restored the neutral and ranges of performer %s on rig %s from %s (%s old)",
            self.performer,
            self.ctx.rig,
            self.path,
            _age(age_s),
        )

    def after_frame(self) -> None:
        """Save when the neutral was just learned, or every SAVE_INTERVAL_S while it adapts."""
        if not learned(self.processor):
            return
        now = self.ctx.clock.monotonic_ns()
        if not self._had_neutral:
            self._had_neutral = True
            self._save("learned the neutral of performer %s: saved to %s")
        elif self.processor.auto is not None and (
            self._last_save_ns is None or now - self._last_save_ns >= SAVE_INTERVAL_S * 1e9
        ):
            self._save("auto range: neutral and ranges of performer %s updated in %s")

    def _save(self, message: str, *, quiet: bool = False) -> None:
        self._last_save_ns = self.ctx.clock.monotonic_ns()
        state = snapshot(self.processor, self.ctx.rig, self.performer, self.ctx.clock.time_ns())
        if self.saved is not None and _same(state, self.saved):
            return
        try:
            save_state(self.path, state)
        except StateError as exc:
            self.ctx.log.warning("%s", exc)
            return
        self.saved = state
        if not quiet:
            self.ctx.log.info(message, self.performer, self.path)

    def close(self) -> None:
        """On the way out: keep the newest state."""
        if learned(self.processor):
            self._save("kept the neutral and ranges of performer %s in %s")


def _same(a: LearnedState, b: LearnedState) -> bool:
    return (a.neutral, a.frame, a.named_neutral, a.neutral_mesh, a.ranges) == (
        b.neutral,
        b.frame,
        b.named_neutral,
        b.neutral_mesh,
        b.ranges,
    )


def _age(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    if seconds < 172800:
        return f"{seconds / 3600:.0f} h"
    return f"{seconds / 86400:.0f} days"


async def serve_features(
    ctx: ServiceContext,
    processor: FeatureProcessor,
    queue: int = 8,
    keeping: StateKeeping | None = None,
    max_age_s: float = DEFAULT_MAX_AGE_S,
) -> None:
    """Compute features for every Points message until cancelled; points of a frame captured
    longer ago than ``max_age_s`` when their turn comes are dropped (0: never)."""
    ctx.log.info("feature processor on %s", ctx.key("points"))
    keeper = None
    if keeping is not None:
        try:
            keeper = _Keeper(ctx, processor, keeping)
        except StateError as exc:
            ctx.log.warning("the learned neutral is not kept: %s", exc)

    def transform(points: Points) -> Features:
        features = processor.process(points)
        for note in processor.notes:
            ctx.log.info("%s", note)
        processor.notes.clear()
        if keeper is not None:
            keeper.after_frame()
        return features

    try:
        await serve_transform(
            ctx, "points", Points, "features", transform, queue, max_age_s=max_age_s or None
        )
    finally:
        if keeper is not None:
            with contextlib.suppress(Exception):  # never let a full disk hide the real error
                keeper.close()
