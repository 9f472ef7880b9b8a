"""The tracker's model calls, as the CPU budget and ``bench run`` measure them."""

from __future__ import annotations

import itertools
import math
import time
from typing import Any

import numpy as np
import pytest

from facesynth.app.bench.budget import model_calls_ms
from facesynth.app.data import sample_video
from facesynth.services.points.tracker.offline import iter_video_frames
from facesynth.services.points.tracker.tracker import FaceTracker


def _after_setup(calls: list[Any]) -> list[Any]:
    """The calls after the tracker's set-up (its constructor resets it)."""
    return list(itertools.dropwhile(lambda call: isinstance(call, str), calls))


@pytest.fixture
def calls(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """Each frame the tracker processes (its first pixel row), and each reset, in order."""
    seen: list[Any] = []
    process, reset = FaceTracker.process, FaceTracker.reset

    def spy_process(self: FaceTracker, image: np.ndarray) -> Any:
        seen.append(image[0].copy())
        return process(self, image)

    def spy_reset(self: FaceTracker) -> None:
        seen.append("reset")
        reset(self)

    monkeypatch.setattr(FaceTracker, "process", spy_process)
    monkeypatch.setattr(FaceTracker, "reset", spy_reset)
    return seen


def test_skipped_frames_are_tracked_in_order_before_the_timed_ones(calls: list[Any]) -> None:
    ms = model_calls_ms("full", 1, sample_video(), 3, skip=4)
    calls = _after_setup(calls)
    assert math.isfinite(ms) and ms > 0
    frames = [f[0] for f in iter_video_frames(sample_video(), 7)]
    # the video's first 7 frames once each, in order, no reset: a chain's warm-up, then 3 timed
    assert not any(isinstance(call, str) for call in calls)
    assert len(calls) == 7
    assert all(np.array_equal(a, b) for a, b in zip(calls, frames, strict=True))


def test_without_skip_the_first_frames_warm_up_and_are_timed_again(calls: list[Any]) -> None:
    model_calls_ms("full", 1, sample_video(), 6)
    calls = _after_setup(calls)
    # 5 warm-up frames, a reset, then all 6 timed
    assert [isinstance(call, str) for call in calls] == [False] * 5 + [True] + [False] * 6


def test_no_frame_after_the_skip_gives_nan() -> None:
    assert math.isnan(model_calls_ms("full", 1, sample_video(), 3, skip=472))


def test_with_fps_the_timed_frames_come_at_that_rate(monkeypatch: pytest.MonkeyPatch) -> None:
    """As a chain's points stage gets them: one every 1 / fps seconds, not back to back."""
    starts: list[float] = []
    process = FaceTracker.process

    def spy_process(self: FaceTracker, image: np.ndarray) -> Any:
        starts.append(time.perf_counter())
        return process(self, image)

    monkeypatch.setattr(FaceTracker, "process", spy_process)
    ms = model_calls_ms("full", 1, sample_video(), 4, skip=2, fps=10)
    assert math.isfinite(ms) and ms > 0
    timed = starts[2:]  # after the two warm-up frames
    assert len(timed) == 4
    # Each in its slot, 0.1 s after the one before (back to back they are ~10 ms apart); a
    # frame late to its slot leaves the next a shorter wait, so the slots are what is held.
    since_first = np.array(timed) - timed[0]
    assert (since_first >= np.arange(4) * 0.1 - 0.02).all(), since_first
    assert np.diff(timed).min() > 0.05, np.diff(timed)
