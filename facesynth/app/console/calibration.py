"""The performer calibration, run from the console with the page watching.

The same recording as ``facesynth calibrate`` (:mod:`facesynth.app.calibrate_cli`: the steps,
the prompts, :class:`~services.features.calibrate.CalibrationRecorder`), from the console's
camera or video: every frame goes through the tracker here, and the page is sent the frame,
its landmarks and where the run is (``calibration`` messages: the step, its prompt, the
seconds left in it, then the file written or the error). A video is played at its own pace so
that the countdown is the one the performer saw. It runs in a thread (the tracker blocks);
:meth:`CalibrationRun.cancel` stops it between frames, writing nothing.
"""

from __future__ import annotations

import argparse
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from facesynth.app.calibrate_cli import calibration_inputs, default_path, save_recorded
from facesynth.runtime.keys import check_name
from facesynth.services.features.calibrate import PROMPTS, CalibrationStepError, step_at

#: Frames sent to the page per second at most (the tracker sees every frame).
PAGE_FPS = 15.0
Report = Callable[[str, Any], None]


class CalibrationRun:
    """One calibration called ``name`` from the sources the command line chose."""

    def __init__(self, name: str, args: argparse.Namespace, out_dir: Path | None = None) -> None:
        check_name(name, "calibration")  # ValueError with the rule, for the page
        self.name = name
        self.args = args
        self.path = (out_dir / f"{name}.json") if out_dir is not None else default_path(name)
        self._cancelled = threading.Event()
        #: Frames used per step, once written.
        self.frames_used: dict[str, int] = {}

    def cancel(self) -> None:
        """Stop after the current frame; nothing is written."""
        self._cancelled.set()

    def run(self, report: Report) -> Path:
        """Record and save the calibration; ``report(kind, payload)`` is called from this
        thread with ``frame`` (a Frame), ``points`` (Points) and ``calibration`` (a dict: the
        step, its prompt, the seconds left in it)."""
        from facesynth.runtime.frames import encode_frame
        from facesynth.services.sensor.sources.base import pixels

        backend, source, schedule, recorder = calibration_inputs(self.name, self.args)
        live = source.info.live
        end_s = max(end for _, _, end in schedule)
        started = time.monotonic()
        shown = 0.0
        try:
            for seq, (image, t_media_ns) in enumerate(source.frames()):
                if self._cancelled.is_set():
                    raise CalibrationStepError("calibration cancelled: nothing written")
                t_s = t_media_ns / 1e9
                if t_s >= end_s:
                    break
                if not live:  # a video at its own pace, so the countdown is real
                    time.sleep(max(0.0, started + t_s - time.monotonic()))
                if image is None:
                    raise CalibrationStepError("the tracker needs images: give --camera or --video")
                frame = encode_frame(
                    pixels(image), seq=seq, t_capture_ns=time.time_ns(), t_media_ns=t_media_ns,
                    encoding="jpeg", quality=80,
                )  # fmt: skip
                points = backend.process(frame)
                found = step_at(schedule, t_s)
                if found is not None:
                    step, t_in = found
                    recorder.add(step, t_in, points)
                    ends = next(e for s, b, e in schedule if s == step and b <= t_s < e)
                    status = {"step": step, "prompt": PROMPTS[step], "left_s": round(ends - t_s, 1)}
                else:
                    status = {"step": None, "prompt": "get ready", "left_s": None}
                now = time.monotonic()
                if now - shown >= 1 / PAGE_FPS:
                    shown = now
                    report("points", points)
                    report("frame", frame)
                    report("calibration", {"state": "running", "name": self.name, **status})
        finally:
            source.close()
        save_recorded(recorder, self.path)
        self.frames_used = {step: used for step, (used, _) in recorder.summary().items()}
        return self.path
