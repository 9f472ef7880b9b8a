"""``facesynth calibrate NAME``: guide a performer through the face-section expressions.

Live camera: prompts on the terminal, ``--seconds`` per step (10 steps x 4 s = 40 s by default).
Video: ``--schedule "neutral=7.0-9.2,smile=14-15,…"`` says when each step happens. Frames go
straight through the tracker (P of :class:`facesynth.app.engine.stepped.SteppedChain`) and the
feature maths in this process (no bus needed); the result
is written atomically to ``~/.config/facesynth/calibrations/NAME.json`` (or ``--out``), where
``--calibration NAME`` finds it.
"""

from __future__ import annotations

import argparse
import datetime
import sys
import time
from pathlib import Path
from typing import TextIO

from facesynth.app.engine.stepped import SteppedChain, sensor_frame
from facesynth.app.nodes import PointsNode, SensorNode
from facesynth.app.stage_args import apply_arguments
from facesynth.app.wiring import build_backend, build_source
from facesynth.runtime.calibration import CALIBRATIONS, save_calibration
from facesynth.runtime.keys import check_name
from facesynth.runtime.outputs import check_output
from facesynth.services.features.calibrate import (
    PROMPTS,
    STEPS,
    CalibrationRecorder,
    CalibrationStepError,
    parse_schedule,
    step_at,
)
from facesynth.services.features.expressions import raw_features
from facesynth.services.points.backends.base import PointsBackend
from facesynth.services.sensor.sources.base import FrameSource, pixels

#: Seconds skipped at the start of each live step: the performer is still changing expression.
LIVE_SETTLE_S = 0.7


def default_path(name: str) -> Path:
    """Where a calibration called ``name`` is saved by default."""
    return CALIBRATIONS.search_dirs()[-1] / f"{name}.json"


def guided_schedule(args: argparse.Namespace, live: bool) -> list[tuple[str, float, float]]:
    """``--schedule`` if given; else, live, ``--steps`` of ``--seconds`` each, one after another."""
    if args.schedule:
        return parse_schedule(args.schedule)
    if not live:
        raise CalibrationStepError(
            "a recording has no prompts: give --schedule STEP=START-END,… (seconds into it)"
        )
    steps = [s.strip() for s in args.steps.split(",") if s.strip()]
    unknown = [s for s in steps if s not in STEPS]
    if unknown or "neutral" not in steps:
        raise CalibrationStepError(f"--steps needs neutral and known steps ({', '.join(STEPS)})")
    if not args.seconds >= 1.5:
        raise CalibrationStepError("--seconds must be at least 1.5")
    return [(step, i * args.seconds, (i + 1) * args.seconds) for i, step in enumerate(steps)]


def calibration_inputs(
    name: str, args: argparse.Namespace
) -> tuple[PointsBackend, FrameSource, list[tuple[str, float, float]], CalibrationRecorder]:
    """The tracker, the frame source (the caller closes it), the schedule and the recorder of
    a calibration called ``name``, from the command line's points and sensor options."""
    _, backend_config = apply_arguments("points", PointsNode(), args)
    _, source_config = apply_arguments("sensor", SensorNode(), args)
    backend = build_backend(backend_config)
    source = build_source(source_config, backend.frame_count())
    if backend.needs_pixels() and source.info.name == "ticks":
        raise CalibrationStepError("the tracker needs images: give --camera or --video")
    schedule = guided_schedule(args, source.info.live)
    # A schedule marks exactly when each expression is held; live prompts need reaction time.
    settle_s = 0.0 if args.schedule else LIVE_SETTLE_S
    return backend, source, schedule, CalibrationRecorder(name, raw_features, settle_s=settle_s)


def save_recorded(recorder: CalibrationRecorder, path: Path) -> None:
    """Write the calibration ``recorder`` holds to ``path``, dated now."""
    created = datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
    save_calibration(recorder.build(created=created), path)


def run_calibration(args: argparse.Namespace, out: TextIO | None = None) -> Path:
    """Record and save a calibration; return its path. Progress goes to ``out`` (stdout)."""
    out = out if out is not None else sys.stdout
    check_name(args.name, "calibration")
    if args.out:
        check_output(args.out, "calibration")
    else:  # the default place (~/.config/facesynth/calibrations) is made whole
        check_output(default_path(args.name), "calibration", make_parents=True)
    backend, source, schedule, recorder = calibration_inputs(args.name, args)
    chain = SteppedChain(backend)  # P alone: the recorder takes the points
    end_s = max(end for _, _, end in schedule)
    current = None
    try:
        for seq, (image, t_media_ns) in enumerate(source.frames()):
            t_s = t_media_ns / 1e9
            if t_s >= end_s:
                break
            found = step_at(schedule, t_s)
            if found is None:
                continue
            step, t_in_step = found
            if step != current and source.info.live:
                current = step
                print(
                    f"\n>>> {step.replace('_', ' ').upper()}: {PROMPTS[step]}", file=out, flush=True
                )
            frame = sensor_frame(pixels(image), seq, t_media_ns, t_capture_ns=time.time_ns())
            points = chain.step(frame).points
            assert points is not None
            recorder.add(step, t_in_step, points)
    finally:
        source.close()
    path = Path(args.out) if args.out else default_path(args.name)
    save_recorded(recorder, path)
    for step, (used, seen) in recorder.summary().items():
        print(f"{step:<15} {used:>4} of {seen:>4} frames used", file=out)
    print(f"calibration {args.name!r} written to {path}", file=out)
    return path
