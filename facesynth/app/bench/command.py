"""``facesynth bench``: its arguments and its command, one benchmark per ``what``."""

from __future__ import annotations

import argparse
from pathlib import Path

from facesynth.app.wiring import OptionError


def add_bench_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``facesynth bench``; each help says which benchmarks read it."""
    p.add_argument(
        "what",
        choices=(
            "chain",
            "fanout",
            "tracker",
            "smoothing",
            "recording",
            "face",
            "fidelity",
            "drivers",
            "robot",
        ),
    )
    p.add_argument("video", nargs="?", help="video (default: the bundled performer video)")
    p.add_argument(
        "--seconds",
        type=float,
        default=None,
        help="chain: seconds of real-time input (default 15); fanout: per run (default 10); "
        "face: seconds per row (default 3)",
    )
    p.add_argument(
        "--rate", type=float, default=100.0, help="face: commands per second (default 100)"
    )
    p.add_argument(
        "--fps", type=float, default=30.0, help="chain, recording: frame rate (default 30)"
    )
    p.add_argument(
        "--openface-csv", metavar="PATH", help="chain: replay these landmarks instead of tracking"
    )
    p.add_argument(
        "--frames",
        type=int,
        help="tracker: frames to measure; robot: the video's first N frames (default: all); "
        "drivers --emulated: frames per driver (default 150)",
    )
    p.add_argument(
        "--emulated",
        action="store_true",
        help="drivers: also run each driver against its device emulator (a source checkout's "
        "tests/control/fake_devices) at --fps and print C's CPU per frame and the bus bytes "
        "the emulators counted",
    )
    p.add_argument(
        "--encoding",
        default="jpeg",
        metavar="A,B",
        help="chain: frame encodings to compare, jpeg and/or raw (default jpeg; raw frames go "
        "through Zenoh's shared memory between processes on one host)",
    )
    p.add_argument(
        "--threads", default="1", metavar="N,M", help="chain: tracker inference threads to compare"
    )
    p.add_argument(
        "--robots",
        default="1,4,8,16,32",
        metavar="N,M",
        help="fanout: robot counts to sweep (default 1,4,8,16,32)",
    )
    p.add_argument(
        "--layout",
        default=None,
        metavar="A,B",
        help="chain: processes (one per service) and/or board (features, translator and "
        "control in one process), default processes,board; fanout: how robots' nodes share "
        "processes, compared side by side: processes (one per translator and per control "
        "interface), robot (one per robot), shared (one for all robots), shared:K (K "
        "processes); default processes,shared",
    )
    p.add_argument(
        "--sched",
        default="normal",
        metavar="A,B",
        help="chain, fanout: scheduling of every process to compare: normal and/or realtime "
        "(SCHED_FIFO priority 10; needs CAP_SYS_NICE)",
    )
    p.add_argument(
        "--baseline",
        metavar="DIR",
        help="chain: also run each variant (without realtime) from this facesynth source tree, "
        "e.g. an older version: git archive v1 | tar -x -C DIR",
    )
    p.add_argument(
        "--runs",
        type=int,
        default=1,
        metavar="N",
        help="chain: N interleaved runs of every variant (default 1; the goals ask for 3)",
    )
    p.add_argument(
        "--hops",
        action="store_true",
        help="chain: also time each hop and show which hops grow in the slowest frames "
        "(the observer then receives every stage's messages, which costs some CPU)",
    )
    p.add_argument(
        "--profile",
        action="append",
        metavar="NAME|PATH",
        help="smoothing, drivers: profile to measure (default paper16); robot: a profile to "
        "drive the heads with, repeatable, a name or a file (e.g. X.learned; default paper16, "
        "head16, head16_bs)",
    )
    p.add_argument(
        "--head",
        action="append",
        metavar="NAME|PATH",
        help="robot: a simulated head to drive, repeatable, a bundled name or a head file "
        "(default: every bundled head)",
    )
    p.add_argument(
        "--json",
        nargs="?",
        const="-",
        metavar="FILE",
        help="robot: print the result as JSON instead of the table, or write it to FILE as "
        "well as printing the table",
    )
    p.add_argument(
        "--driver",
        metavar="NAME",
        help="robot: drive a head outside this process in real time through this servo "
        "driver (maestro, arduino, ssc32; e.g. facesynth simhead's serial port) instead of "
        "the simulated heads in process; needs --camera or --ros2-image-topic",
    )
    p.add_argument("--port", metavar="PORT", help="robot: the --driver's serial port")
    p.add_argument(
        "--camera",
        metavar="CAMERA",
        help="robot: the camera watching the --driver's head: a device index, a /dev/video* "
        "path or a stream URL (e.g. http://127.0.0.1:8080/camera.mjpg)",
    )
    p.add_argument(
        "--ros2-image-topic",
        metavar="TOPIC",
        help="robot: instead of --camera, the robot's camera on ROS 2 (sensor_msgs "
        "CompressedImage JPEG on a topic ending in /compressed, else Image rgb8, bgr8 or "
        "mono8; the [ros2] extra)",
    )
    p.add_argument(
        "--closed-loop",
        action="store_true",
        help="robot: also drive each learned --profile with T's loop closed through the "
        "head's camera, beside its open loop (simulated heads in process)",
    )
    p.add_argument(
        "--track", help="smoothing: a facesynth track file to measure tracking noise from"
    )
    p.add_argument(
        "--mode",
        default="client",
        metavar="A,B",
        help="chain: Zenoh modes of the services to compare, client and/or peer (default client)",
    )
    p.add_argument(
        "--backends", default="litert,opencv", help="tracker: inference backends to compare"
    )
    p.add_argument(
        "--models",
        metavar="A,B",
        help="tracker models to compare (tracker, fidelity: default fast,full; chain, fanout: "
        "default full)",
    )
    p.add_argument(
        "--profiles",
        metavar="A,B",
        help="fidelity: profiles to measure (default: every shipped one)",
    )
    p.add_argument(
        "--repeat",
        type=int,
        default=1,
        metavar="N",
        help="tracker, drivers --emulated: N interleaved runs, medians reported (default 1; "
        "shared machines: 5)",
    )
    p.add_argument(
        "--mediapipe-python",
        metavar="PATH",
        help="tracker: also time MediaPipe's own trackers with this Python (a venv with "
        "mediapipe==0.10.21; see facesynth/app/bench/mediapipe_helper.py)",
    )
    p.add_argument(
        "--mediapipe-task",
        metavar="PATH",
        help="tracker: the face_landmarker.task bundle for --mediapipe-python",
    )
    p.add_argument(
        "--minutes", type=float, default=10.0, help="recording: session length (default 10)"
    )


def cmd_bench(args: argparse.Namespace) -> int:
    """``facesynth bench chain|tracker|smoothing|recording|face|fidelity|drivers|robot``."""
    if args.what == "fidelity":
        return _bench_fidelity(args)
    if args.what == "robot":
        from facesynth.app.bench.robot_command import bench_robot_command

        return bench_robot_command(args)
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
    from facesynth.services.points.tracker.landmarkers import model_names

    backends = tuple(b for b in args.backends.split(",") if b)
    models = tuple(m for m in (args.models or "fast,full").split(",") if m)
    unknown = [m for m in models if m not in model_names()]
    if unknown or not models:
        choices = ", ".join(model_names())
        raise OptionError(f"--models: unknown {unknown}; choose from {choices}")
    result = bench_tracker(
        args.video or str(sample_video()),
        backends=backends,
        frames=args.frames,
        models=models,
        repeat=args.repeat,
        mediapipe_python=args.mediapipe_python,
        mediapipe_task=args.mediapipe_task,
    )
    print(format_bench(result))
    return 0


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
    from facesynth.services.points.tracker.landmarkers import model_names

    if args.runs < 1:
        raise OptionError("--runs must be at least 1")
    threads = [int(t) for t in _choices(args.threads, "--threads", tuple(map(str, range(1, 9))))]
    chosen = variants(
        encodings=_choices(args.encoding, "--encoding", ("jpeg", "raw")),
        models=_choices(args.models or "full", "--models", tuple(model_names())),
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
    # The tracker's own model calls, which the points stage may spend beyond its budget.
    model_ms = {}
    if not args.openface_csv:
        for variant in chosen:
            key = (variant.model, variant.threads)
            if key not in model_ms:
                model_ms[key] = model_calls_ms(*key, Path(args.video or sample_video()))
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
    from facesynth.services.points.tracker.landmarkers import model_names

    models = tuple(m for m in (args.models or "fast,full").split(",") if m)
    unknown = [m for m in models if m not in model_names()]
    if unknown or not models:
        choices = ", ".join(model_names())
        raise OptionError(f"--models: unknown {unknown}; choose from {choices}")
    profiles = tuple(p for p in (args.profiles or ",".join(PROFILES)).split(",") if p)
    for profile in profiles:
        resolve_profile(profile)  # a clear error for an unknown name before any tracking
    rows = bench_fidelity(args.video or str(sample_video()), models, profiles)
    print(format_fidelity(rows))
    return 0
