"""The CPU budget of ``facesynth bench chain``: what each process may spend per frame, and the
tracker's own model calls that the points stage is allowed on top of its budget.

The budget (issue 19): sensor ≤ 1.5 ms of CPU per frame; points ≤ its model calls + 1.5 ms;
features ≤ 0.5; translator ≤ 0.3; control ≤ 0.3; router ≤ 0.5; the five-process chain ≤ 10 ms;
F + T + C in one board process ≤ 1 ms. The model calls are measured in the benchmark's own
process, after the runs, on the same video: the CPU time of the tracker's raw inference calls
(:meth:`Model.run <facesynth.services.points.tracker.runtimes.base.Model.run>`: detector, landmarks,
blendshapes), per frame, with the frames paced at the chain's rate as the points stage gets them:
a core that idles between frames runs the next one cold, and the same calls then cost more
than back to back (measured 2026-11-28 on this project's machine kind: 5.5–6.3 ms a frame back
to back, 6.6–6.8 at 30 fps; see the benchmarks page).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

#: CPU ms per frame each process may spend (points: beyond its model calls).
BUDGET_MS = {
    "sensor": 1.5,
    "points": 1.5,
    "features": 0.5,
    "translator": 0.3,
    "control": 0.3,
    "router": 0.5,
}
#: The five-process chain, the router included, and F + T + C in one process.
CHAIN_BUDGET_MS = 10.0
BOARD_BUDGET_MS = 1.0


def _models_of(tracker: Any) -> Iterator[Any]:
    """Every loaded model a tracker calls (its detector's, its landmarker's parts')."""
    from facesynth.services.points.tracker.runtimes.base import Model

    seen: set[int] = set()
    todo = [tracker]
    for _ in range(3):  # tracker → detector / landmarker → mesh, blendshapes → model
        found = []
        for owner in todo:
            for value in vars(owner).values():
                if isinstance(value, Model):
                    if id(value) not in seen:
                        seen.add(id(value))
                        yield value
                elif hasattr(value, "__dict__") and not isinstance(value, type):
                    found.append(value)
        todo = found


def _timed(run: Callable[[], Any], spent: list[float]) -> Callable[[], Any]:
    def timed_run() -> Any:
        start = time.process_time()
        try:
            return run()
        finally:
            spent[0] += time.process_time() - start

    return timed_run


def model_calls_ms(
    model: str,
    threads: int,
    video: Path,
    frames: int = 150,
    *,
    skip: int = 0,
    fps: float | None = None,
) -> float:
    """CPU ms per frame of the tracker's raw model calls over the video's first ``frames``
    frames (decoded beforehand, so decoding is not counted). With ``skip``, over the
    ``frames`` frames after the first ``skip``, which are tracked first, untimed, as a
    chain's warm-up is (``facesynth bench run``: the frames its ``run`` is measured on).
    With ``fps``, the timed frames are tracked one every ``1 / fps`` seconds, as a chain's
    points stage gets them (``bench chain``); without it, back to back (``bench run``, whose
    ``run --fast`` tracks as fast as it can)."""
    from facesynth.services.points.backends.tracker import TrackerBackend, TrackerConfig
    from facesynth.services.points.tracker.offline import iter_video_frames

    # The points service's own tracker, set up as it sets it up.
    tracker = TrackerBackend(TrackerConfig(model=model, threads=threads)).tracker
    spent = [0.0]
    for loaded in _models_of(tracker):
        # This instance only: the benchmark's own tracker, counting its inference calls.
        loaded.run = _timed(loaded.run, spent)
    images = list(iter_video_frames(video, skip + frames))
    warmup, images = images[:skip], images[skip:]
    if not images:
        return float("nan")
    if warmup:  # the frames before, tracked in order: the tracker's state on the first one
        for image in warmup:
            tracker.process(image)
    else:
        for image in images[:5]:  # warm-up: first calls allocate
            tracker.process(image)
        tracker.reset()
    spent[0] = 0.0
    start = time.perf_counter()
    for index, image in enumerate(images):
        if fps:
            time.sleep(max(0.0, start + index / fps - time.perf_counter()))
        tracker.process(image)
    return spent[0] * 1e3 / len(images)
