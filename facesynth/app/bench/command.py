"""``facesynth bench``: its command, one benchmark per ``what`` (its options:
:mod:`facesynth.app.bench.arguments`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from facesynth.app.bench.arguments import unread_options
from facesynth.app.wiring import OptionError


def cmd_bench(args: argparse.Namespace) -> int:
    """``facesynth bench chain|tracker|smoothing|recording|face|fidelity|drivers|robot``."""
    unread = unread_options(args)
    if unread:
        raise OptionError("; ".join(unread))
    if args.what == "fidelity":
        return _bench_fidelity(args)
    if args.what == "robot":
        from facesynth.app.bench.robot_command import bench_robot_command

        return bench_robot_command(args)
    if args.what == "run":
        from facesynth.app.bench.run_compare import bench_run_command

        return bench_run_command(args)
    if args.what == "drivers":
        from facesynth.app.bench.bus_time import bus_frames, format_bus_frames
        from facesynth.app.bench.drivers import bench_drivers, format_drivers

        frames = 150 if args.frames is None else args.frames
        if args.emulated:
            from facesynth.app.bench.driver_cpu import check_options

            check_options(frames=frames, fps=args.fps, repeat=args.repeat)  # errors first
        profile, costs = bench_drivers(_one_profile(args))
        print(format_drivers(profile, costs))
        print(format_bus_frames(profile, bus_frames(profile)))
        if args.emulated:
            from facesynth.app.bench.driver_cpu import bench_cpu, format_cpu

            runs = bench_cpu(profile, frames=frames, fps=args.fps, repeat=args.repeat)
            print(format_cpu(profile, runs, args.fps))
        return 0
    if args.what == "smoothing":
        from facesynth.app.bench.smoothing import bench_smoothing, format_smoothing

        print(format_smoothing(bench_smoothing(_one_profile(args), track=args.track)))
        return 0
    if args.what == "recording":
        from facesynth.app.bench.recording import bench_recording, format_recording_bench

        print(format_recording_bench(bench_recording(minutes=args.minutes, fps=args.fps)))
        return 0
    if args.what == "face":
        from facesynth.app.bench.face import bench_face, format_face

        print(format_face(bench_face(seconds=args.seconds or 3.0, rate=args.rate)))
        return 0
    if args.what == "chain":
        return _bench_chain(args)
    if args.what == "fanout":
        return _bench_fanout(args)
    from facesynth.app.bench.tracker import bench_tracker, format_bench
    from facesynth.app.data import sample_video

    backends = tuple(b for b in args.backends.split(",") if b)
    result = bench_tracker(
        args.video or str(sample_video()),
        backends=backends,
        frames=args.frames,
        models=_models(args),
        repeat=args.repeat,
        mediapipe_python=args.mediapipe_python,
        mediapipe_task=args.mediapipe_task,
    )
    print(format_bench(result))
    return 0


def _models(args: argparse.Namespace, default: str = "fast,full") -> list[str]:
    """``--models`` (tracker, fidelity: default fast,full; chain, fanout: full), each checked."""
    from facesynth.services.points.tracker.landmarkers import model_names

    return _choices(args.models or default, "--models", tuple(model_names()))


def _one_profile(args: argparse.Namespace) -> str:
    """The profile a one-profile benchmark measures: the last ``--profile`` (or paper16)."""
    return str(args.profile[-1]) if args.profile else "paper16"


def _choices(value: str, flag: str, allowed: tuple[str, ...]) -> list[str]:
    """A comma-separated list of choices (``jpeg,raw``), each checked."""
    chosen = [item.strip() for item in value.split(",") if item.strip()]
    unknown = [item for item in chosen if item not in allowed]
    if unknown or not chosen:
        raise OptionError(
            f"{flag}: unknown {', '.join(unknown) or 'empty list'}; "
            f"choose from {', '.join(allowed)}"
        )
    return chosen


def _bench_chain(args: argparse.Namespace) -> int:
    """``facesynth bench chain``: the variants asked for, side by side, ``--runs`` times."""
    from facesynth.app.bench.budget import model_calls_ms
    from facesynth.app.bench.chain import LAYOUTS, SCHEDULES, bench_chain, variants
    from facesynth.app.bench.chain_report import format_chain_bench
    from facesynth.app.data import sample_video

    if args.runs < 1:
        raise OptionError("--runs must be at least 1")
    threads = [int(t) for t in _choices(args.threads, "--threads", tuple(map(str, range(1, 9))))]
    chosen = variants(
        encodings=_choices(args.encoding, "--encoding", ("jpeg", "raw")),
        models=_models(args, "full"),
        threads=threads,
        modes=_choices(args.mode, "--mode", ("client", "peer")),
        scheds=_choices(args.sched, "--sched", SCHEDULES),
        baseline=_baseline(args.baseline),
        layouts=_choices(args.layout or ",".join(LAYOUTS), "--layout", LAYOUTS),
    )
    figures = bench_chain(
        chosen,
        runs=args.runs,
        video=args.video,
        seconds=args.seconds or 15.0,
        fps=args.fps,
        openface_csv=args.openface_csv,
        hops=args.hops,
    )
    # The tracker's own model calls, which the points stage may spend beyond its budget, at
    # the chain's frame rate (as the stage makes them).
    model_ms = {}
    if not args.openface_csv:
        video = Path(args.video or sample_video())
        for variant in chosen:
            key = (variant.model, variant.threads)
            if key not in model_ms:
                model_ms[key] = model_calls_ms(*key, video, fps=args.fps)
    print(format_chain_bench(figures, model_ms))
    return 0


def _bench_fanout(args: argparse.Namespace) -> int:
    """``facesynth bench fanout``: one performer, N robots, in each layout, side by side."""
    from facesynth.app.bench.chain import REALTIME_PRIORITY, SCHEDULES
    from facesynth.app.bench.fanout import bench_fanout, check_layout
    from facesynth.app.bench.fanout_report import format_fanout
    from facesynth.services.points.tracker.landmarkers import model_names

    try:
        counts = [int(n) for n in args.robots.split(",") if n.strip()]
    except ValueError:
        raise OptionError(f"--robots: not a list of numbers: {args.robots!r}") from None
    if not counts or min(counts) < 1:
        raise OptionError("--robots: give one or more counts of at least 1, e.g. 1,4,8,16,32")
    if args.runs < 1:
        raise OptionError("--runs must be at least 1")
    (model,) = _single(args.models or "full", "--models", tuple(model_names()))
    (encoding,) = _single(args.encoding, "--encoding", ("jpeg", "raw"))
    (mode,) = _single(args.mode, "--mode", ("client", "peer"))
    (sched,) = _single(args.sched, "--sched", SCHEDULES)
    layout = args.layout or "processes,shared"
    layouts = [item.strip() for item in layout.split(",") if item.strip()]
    try:
        layouts = [check_layout(layout) for layout in layouts]
    except ValueError as exc:
        raise OptionError(f"--layout: {exc}") from None
    if not layouts:
        raise OptionError("--layout: give one or more layouts")
    figures = bench_fanout(
        counts,
        layouts,
        runs=args.runs,
        video=args.video,
        seconds=args.seconds or 10.0,
        fps=args.fps,
        model=model,
        encoding=encoding,
        mode=mode,
        realtime=REALTIME_PRIORITY if sched == "realtime" else None,
    )
    print(format_fanout(figures, model=model, encoding=encoding, mode=mode, sched=sched))
    return 0


def _baseline(path: str | None) -> str:
    """``--baseline DIR``: a source tree holding another facesynth package, or ``""``."""
    if not path:
        return ""
    if not (Path(path) / "facesynth" / "__main__.py").is_file():
        raise OptionError(f"--baseline {path}: no facesynth source tree there (facesynth/ missing)")
    return path


def _single(value: str, flag: str, allowed: tuple[str, ...]) -> list[str]:
    """One choice (``fanout`` compares layouts and robot counts, not these)."""
    chosen = _choices(value, flag, allowed)
    if len(chosen) != 1:
        raise OptionError(f"{flag}: bench fanout takes one value, not {value!r}")
    return chosen


def _bench_fidelity(args: argparse.Namespace) -> int:
    """``facesynth bench fidelity``: synthetic expressions through every profile and model."""
    from facesynth.app.bench.fidelity import PROFILES, bench_fidelity, format_fidelity
    from facesynth.app.data import sample_video
    from facesynth.runtime.profiles import resolve_profile

    models = _models(args)
    profiles = tuple(p for p in (args.profiles or ",".join(PROFILES)).split(",") if p)
    for profile in profiles:
        resolve_profile(profile)  # a clear error for an unknown name before any tracking
    rows = bench_fidelity(args.video or str(sample_video()), models, profiles)
    print(format_fidelity(rows))
    return 0
