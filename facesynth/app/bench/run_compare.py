"""``facesynth bench run``: ``facesynth run`` in one process, measured side by side with the
plain MediaPipe script a user would write instead (:mod:`.plain_mediapipe`), in one command.

Both sides take the same video and the same frames, as fast as they go (``run --fast``; the
plain script's loop never waits): a warm-up of :data:`WARMUP` frames, then ``frames``
measured. Per round, interleaved ``runs`` times:

* ``facesynth run --fast`` (the ``full`` tracker, paper16) as its own process, driving a Mini
  Maestro 24 emulated on a pty (the test suite's, ``tests/control/fake_devices``, in a process
  of its own, so its CPU is not counted) with ``--driver maestro``, or the ``record`` driver
  when no source checkout is there; twice, ``WARMUP + frames`` and ``WARMUP`` frames, and the
  process's user + system time (``RUSAGE_CHILDREN`` around each) of the short run subtracted
  from the long one's: what is left is the CPU of ``frames`` frames, start-up, warm-up and
  shutdown cancelled out;
* the tracker's model calls on the same frames, in this process
  (:func:`facesynth.app.bench.budget.model_calls_ms`, the warm-up tracked first);
* the plain script, in ``--mediapipe-python`` (a venv with ``mediapipe==0.10.21``), which
  counts its own CPU from the frame boundary after its warm-up.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import resource
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import msgspec

from facesynth.app.bench.budget import model_calls_ms
from facesynth.app.bench.device_host import DeviceHost, EmulatorStartError
from facesynth.app.bench.driver_cpu import FAKE_DEVICES
from facesynth.app.bench.run_compare_report import (
    PlainFigures,
    PlainScriptError,
    Round,
    RunFigures,
    format_run_compare,
    parse_plain,
)
from facesynth.app.wiring import OptionError
from facesynth.services.sensor.sources.base import SourceError
from facesynth.services.sensor.sources.video import VideoConfig, VideoSource

#: Frames both sides take before the measured ones.
WARMUP = 30
PLAIN_SCRIPT = Path(__file__).with_name("plain_mediapipe.py")
RUN_TIMEOUT_S = 900.0


@dataclass(frozen=True)
class Options:
    """``facesynth bench run``'s options, checked."""

    video: Path
    frames: int
    runs: int
    mediapipe_python: str | None
    mediapipe_task: str | None


def video_frames(video: Path) -> int:
    """The frame count the video's container announces, as the sensor's video source reads
    it (0 when it cannot be opened)."""
    try:
        source = VideoSource(VideoConfig(path=str(video)))
    except SourceError:
        return 0
    try:
        return source.info.frames or 0
    finally:
        source.close()


def check_options(
    video: Path,
    frames: int | None,
    runs: int,
    mediapipe_python: str | None,
    mediapipe_task: str | None,
) -> Options:
    """The options, each checked (:class:`OptionError`); ``frames`` defaults to 300, or all
    the video has after the warm-up."""
    if runs < 1:
        raise OptionError("--runs must be at least 1")
    if frames is not None and frames < 1:
        raise OptionError("--frames must be at least 1")
    if not video.is_file():
        raise OptionError(f"video not found: {video}")
    available = video_frames(video) - WARMUP
    if available < 1:
        raise OptionError(f"{video}: not a video of more than {WARMUP} frames")
    if frames is None:
        frames = min(300, available)
    if frames > available:
        raise OptionError(
            f"--frames {frames}: {video.name} has {available + WARMUP} frames, so at most "
            f"{available} after the {WARMUP}-frame warm-up"
        )
    if mediapipe_task and not mediapipe_python:
        raise OptionError("--mediapipe-task goes with --mediapipe-python")
    if mediapipe_python:
        if not mediapipe_task:
            raise OptionError("--mediapipe-python needs --mediapipe-task (face_landmarker.task)")
        if not Path(mediapipe_task).is_file():
            raise OptionError(f"MediaPipe task file not found: {mediapipe_task}")
        if not os.access(mediapipe_python, os.X_OK) or Path(mediapipe_python).is_dir():
            raise OptionError(f"--mediapipe-python {mediapipe_python}: not an executable file")
    return Options(video, frames, runs, mediapipe_python, mediapipe_task)


class RunFailed(ValueError):
    """A ``facesynth run`` of the benchmark failed, or executed too few commands."""


class _Summary(msgspec.Struct):
    """The part of ``facesynth run``'s closing JSON line read here."""

    frames: int
    commands: int


def _children_cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_once(video: Path, frames: int, driver_args: list[str]) -> tuple[float, _Summary]:
    """One ``facesynth run --fast`` of the video's first ``frames`` frames as a child process:
    its CPU seconds (every thread) and its summary.

    Raises:
        RunFailed: the run failed, took too long or executed fewer commands than frames.
    """
    command = [sys.executable, "-m", "facesynth", "run", "--fast", "--video", str(video)]
    command += ["--max-frames", str(frames), "--model", "full", "--profile", "paper16"]
    command += ["--rig", f"benchrun{os.getpid()}", "--listen", "tcp/127.0.0.1:0"]
    command += ["--log-level", "WARNING", *driver_args]
    before = _children_cpu_s()
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=RUN_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        raise RunFailed(
            f"facesynth run took over {RUN_TIMEOUT_S:g} s for {frames} frames"
        ) from None
    cpu = _children_cpu_s() - before
    last = (done.stdout.strip().splitlines() or [""])[-1]
    try:
        summary = msgspec.json.decode(last, type=_Summary)
    except msgspec.DecodeError:
        summary = None
    if done.returncode != 0 or summary is None:
        tail = (done.stderr.strip().splitlines() or ["no output"])[-1]
        raise RunFailed(f"facesynth run failed (exit {done.returncode}): {tail}")
    if summary.commands < frames:
        raise RunFailed(f"facesynth run executed {summary.commands} commands of {frames}")
    return cpu, summary


@dataclass(frozen=True)
class Output:
    """Where ``run`` sends its commands: its ``--driver`` arguments, their description, and
    the bytes the device received since the last call (``None``: no device, a file)."""

    args: list[str]
    description: str
    bytes_in: Callable[[], int | None]


@contextlib.contextmanager
def maestro_on_a_pty(folder: Path) -> Iterator[Output]:
    """An emulated Mini Maestro 24 on a pty (a source checkout's), or else the ``record``
    driver into ``folder``."""
    if not (FAKE_DEVICES / "fake_devices" / "maestro.py").is_file():
        out = folder / "commands.jsonl"
        yield Output(
            ["--driver", "record", "--out", str(out)],
            "record driver (no source checkout)",
            lambda: None,
        )
        return
    link = folder / "ttyMaestro"
    try:
        host = DeviceHost(FAKE_DEVICES, "maestro", link)
    except EmulatorStartError as exc:
        raise RunFailed(str(exc)) from None
    with contextlib.closing(host):
        args = ["--driver", "maestro", "--port", str(link), "--maestro-model", "mini24"]
        description = "--driver maestro onto an emulated Mini Maestro 24 on a pty"
        yield Output(args, description, lambda: host.count()[0])


def run_plain(options: Options) -> PlainFigures:
    """One run of the plain MediaPipe script in ``--mediapipe-python``.

    Raises:
        PlainScriptError: it could not be started, failed, or printed no figures.
    """
    assert options.mediapipe_python and options.mediapipe_task
    command = [options.mediapipe_python, str(PLAIN_SCRIPT), "--task", options.mediapipe_task]
    command += ["--video", str(options.video), "--frames", str(options.frames)]
    command += ["--warmup", str(WARMUP), "--out", os.devnull]
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=RUN_TIMEOUT_S)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise PlainScriptError(f"cannot run {options.mediapipe_python}: {exc}") from None
    if done.returncode != 0:
        tail = (done.stderr.strip().splitlines() or ["no output"])[-1]
        raise PlainScriptError(
            f"the plain MediaPipe script failed in {options.mediapipe_python} "
            f"(exit {done.returncode}): {tail}"
        )
    return parse_plain(done.stdout)


def bench_run(options: Options) -> tuple[list[Round], str]:
    """Every round, interleaved (facesynth long, short, model calls, the plain script), and
    a description of the driver ``run`` drove."""
    rounds = []
    with (
        tempfile.TemporaryDirectory(prefix="facesynth-bench-run-") as tmp,
        maestro_on_a_pty(Path(tmp)) as output,
    ):
        for _ in range(options.runs):
            output.bytes_in()
            long_cpu, summary = run_once(options.video, WARMUP + options.frames, output.args)
            device_bytes = output.bytes_in()
            short_cpu, _ = run_once(options.video, WARMUP, output.args)
            model = model_calls_ms("full", 1, options.video, options.frames, skip=WARMUP)
            plain = run_plain(options) if options.mediapipe_python else None
            figures = RunFigures(
                long_cpu, short_cpu, options.frames, summary.commands, model, device_bytes
            )
            rounds.append(Round(figures, plain))
    return rounds, output.description


def bench_run_command(args: argparse.Namespace) -> int:
    """``facesynth bench run [VIDEO] [--frames N] [--runs N] [--mediapipe-python PATH
    --mediapipe-task TASK]``: the rounds, then the report with the goals' verdicts."""
    from facesynth.app.data import sample_video

    options = check_options(
        Path(args.video) if args.video else sample_video(),
        args.frames,
        args.runs,
        args.mediapipe_python,
        args.mediapipe_task,
    )
    load_before = os.getloadavg()
    rounds, driver = bench_run(options)
    after = os.getloadavg()[0]
    load = f"load average {load_before[0]:.1f} → {after:.1f} (1 min), {os.cpu_count()} cores"
    print(
        format_run_compare(
            rounds,
            video=options.video.name,
            frames=options.frames,
            warmup=WARMUP,
            driver=driver,
            load=load,
        )
    )
    return 0


__all__ = ["PlainScriptError", "RunFailed", "bench_run", "bench_run_command", "check_options"]
