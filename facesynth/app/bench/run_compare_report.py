"""``facesynth bench run``'s figures and report: ``run`` in one process beside the plain
MediaPipe script, and the goals of issue 28 against them (pure: no process is started here).

Goals (issue 28, "Goals (benchmarks)"), on CPU per frame of the whole process, start-up
excluded: ``run`` ≤ the tracker's model calls + 2 ms, and ``run`` ≤ 0.7 × the plain script's.
Each verdict is taken on the medians over the interleaved runs.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import msgspec

#: ``run`` may spend this much CPU per frame beyond its tracker's model calls.
RUN_BEYOND_MODEL_MS = 2.0
#: ``run`` may spend this share of the plain script's CPU per frame.
RUN_TO_PLAIN_RATIO = 0.7


class PlainScriptError(ValueError):
    """The plain MediaPipe script failed, or printed something that is not its figures."""


class PlainFigures(msgspec.Struct, forbid_unknown_fields=True):
    """What :mod:`facesynth.app.bench.plain_mediapipe` prints (one JSON object)."""

    script: Literal["plain_mediapipe"]
    mediapipe: str
    frames: int
    warmup: int
    faces: int
    cpu_ms_per_frame: float
    model_calls_ms: float
    wall_ms_per_frame: float
    bytes: int


def parse_plain(stdout: str) -> PlainFigures:
    """The plain script's figures from its standard output (its last non-empty line).

    Raises:
        PlainScriptError: no output, not the script's JSON object, or figures out of range
            (negative, not finite, no frames, or other than 35 bytes a frame written).
    """
    lines = [line for line in stdout.splitlines() if line.strip()]
    if not lines:
        raise PlainScriptError("the plain MediaPipe script printed nothing")
    try:
        figures = msgspec.json.decode(lines[-1], type=PlainFigures)
    except msgspec.DecodeError as exc:
        raise PlainScriptError(
            f"the plain MediaPipe script's output is not its figures: {exc}"
        ) from None
    times = (figures.cpu_ms_per_frame, figures.model_calls_ms, figures.wall_ms_per_frame)
    if not all(math.isfinite(t) and t >= 0 for t in times):
        raise PlainScriptError(f"the plain MediaPipe script reported bad times: {times}")
    if figures.frames < 1 or not 0 <= figures.faces <= figures.frames:
        raise PlainScriptError(
            f"the plain MediaPipe script reported {figures.faces} faces in {figures.frames} frames"
        )
    if figures.bytes != 35 * figures.frames:  # 0x9F, 16, 0, then 16 two-byte targets a frame
        raise PlainScriptError(
            f"the plain MediaPipe script wrote {figures.bytes} bytes for {figures.frames} "
            "frames, not 35 a frame"
        )
    return figures


@dataclass(frozen=True)
class RunFigures:
    """One ``facesynth run --fast`` measurement: a long and a short run, subtracted."""

    long_cpu_s: float
    short_cpu_s: float
    frames: int  # the frames the long run had beyond the short one
    commands: int  # servo commands the long run's controller executed
    model_calls_ms: float  # the tracker's model calls per frame, on the same frames
    device_bytes: int | None = None  # bytes the Maestro received in the long run

    @property
    def cpu_ms_per_frame(self) -> float:
        """The process's CPU per frame, start-up (the short run) subtracted."""
        return (self.long_cpu_s - self.short_cpu_s) * 1e3 / self.frames


@dataclass(frozen=True)
class Round:
    """One interleaved round: facesynth's figures, and the plain script's when it ran."""

    run: RunFigures
    plain: PlainFigures | None


@dataclass(frozen=True)
class Verdict:
    """A goal against a figure: ``figure ≤ limit``."""

    goal: str
    figure: float
    limit: float

    @property
    def met(self) -> bool:
        return self.figure <= self.limit

    def line(self) -> str:
        how = "met" if self.met else "missed"
        return (
            f"  {self.goal}: {self.figure:.2f} ≤ {self.limit:.2f} ms — {how} by "
            f"{abs(self.limit - self.figure):.2f} ms"
        )


def verdicts(run_cpu_ms: float, model_ms: float, plain_cpu_ms: float | None) -> list[Verdict]:
    """Issue 28's goals for ``run`` (the plain-script one only when it ran)."""
    out = [Verdict("run ≤ model calls + 2 ms", run_cpu_ms, model_ms + RUN_BEYOND_MODEL_MS)]
    if plain_cpu_ms is not None:
        out.append(
            Verdict("run ≤ 0.7 × plain script", run_cpu_ms, RUN_TO_PLAIN_RATIO * plain_cpu_ms)
        )
    return out


def _median(values: Sequence[float]) -> float:
    return statistics.median(values) if values else float("nan")


def format_run_compare(
    rounds: Sequence[Round], *, video: str, frames: int, warmup: int, driver: str, load: str
) -> str:
    """The whole report: each round's figures, the medians and the goals' verdicts."""
    lines = [
        f"facesynth bench run: `facesynth run --fast` (full tracker, {driver}) beside a plain "
        f"MediaPipe script, {video}, {frames} frames measured after {warmup}, as fast as "
        "each goes; CPU = the whole process's user + system per frame, start-up excluded",
        "",
        f"{'round':>5}  {'run CPU':>8}  {'model':>6}  {'plain CPU':>9}  {'MP model':>8}  "
        f"{'run/plain':>9}  notes",
    ]
    for i, r in enumerate(rounds, 1):
        plain = r.plain
        cells = (
            f"{plain.cpu_ms_per_frame:9.2f}  {plain.model_calls_ms:8.2f}  "
            f"{r.run.cpu_ms_per_frame / plain.cpu_ms_per_frame:9.2f}"
            if plain and plain.cpu_ms_per_frame > 0
            else f"{'—':>9}  {'—':>8}  {'—':>9}"
        )
        notes = f"{r.run.commands} commands"
        if r.run.device_bytes is not None:
            notes += f" ({r.run.device_bytes} bytes to the Maestro)"
        if plain:
            notes += f"; plain: {plain.faces}/{plain.frames} faces, MediaPipe {plain.mediapipe}"
        lines.append(
            f"{i:5d}  {r.run.cpu_ms_per_frame:8.2f}  {r.run.model_calls_ms:6.2f}  {cells}  {notes}"
        )
    run_cpu = _median([r.run.cpu_ms_per_frame for r in rounds])
    model = _median([r.run.model_calls_ms for r in rounds])
    plains = [r.plain.cpu_ms_per_frame for r in rounds if r.plain]
    plain_cpu = _median(plains) if plains else None
    lines += [
        "",
        f"medians of {len(rounds)} run(s), ms per frame: run {run_cpu:.2f} (model calls "
        f"{model:.2f}, the rest {run_cpu - model:.2f})"
        + (f"; plain script {plain_cpu:.2f}" if plain_cpu is not None else ""),
        f"machine: {load}",
    ]
    if plain_cpu is None:
        lines.append(
            "the plain MediaPipe script was not run (give --mediapipe-python PATH "
            "--mediapipe-task face_landmarker.task)"
        )
    lines.append("goals (issue 28):")
    lines += [v.line() for v in verdicts(run_cpu, model, plain_cpu)]
    return "\n".join(lines)
