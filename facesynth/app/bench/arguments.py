"""``facesynth bench``'s options; each help says which benchmarks read it, and
:data:`READERS` says it to the command: an option given to a benchmark that does not read it
is refused (:func:`unread_options`) rather than silently ignored."""

from __future__ import annotations

import argparse
from typing import Final

from facesynth.app.learn.babble_flags import add_rig_flags, rig_flags_given

#: The benchmarks that read each option (its dest), as its help says.
READERS: Final[dict[str, frozenset[str]]] = {
    dest: frozenset(kinds.split())
    for dest, kinds in {
        "video": "chain fanout tracker fidelity robot run",
        "seconds": "chain fanout face",
        "rate": "face",
        "fps": "chain fanout recording drivers",
        "openface_csv": "chain",
        "frames": "tracker robot drivers run",
        "emulated": "drivers",
        "encoding": "chain fanout",
        "threads": "chain",
        "robots": "fanout",
        "layout": "chain fanout",
        "sched": "chain fanout",
        "baseline": "chain",
        "runs": "chain fanout run",
        "hops": "chain",
        "profile": "smoothing drivers robot",
        "head": "robot",
        "json": "robot",
        "closed_loop": "robot",
        "planned": "robot",
        "learn_poses": "robot",
        "calibration": "robot",
        "track": "smoothing",
        "mode": "chain fanout",
        "backends": "tracker",
        "models": "tracker fidelity chain fanout",
        "profiles": "fidelity robot",
        "repeat": "tracker drivers",
        "mediapipe_python": "tracker run",
        "mediapipe_task": "tracker run",
        "minutes": "recording",
    }.items()
}

#: ``bench robot``'s rig for a head outside this process, as ``facesynth learn`` and ``plan``
#: take it (:mod:`facesynth.app.learn.babble_flags`): the camera watching the head and its servo
#: driver, each with every plugin's options, neither with a default. The tracker on the head's
#: frames is the likeness measure's own, so it is not an option. Only ``bench robot`` reads them.
RIG: Final[dict[str, str | None]] = {"sensor": None, "control": None}

#: Why a benchmark other than ``robot`` refuses ``--calibration`` (the performer's calibration
#: for her F and T) rather than ignore it.
NO_CALIBRATION: Final[dict[str, str]] = {
    "fidelity": "its faces are synthetic, F taking each one's neutral from its still face",
    "smoothing": "it feeds T synthetic features, with no F",
    "chain": "it times the chain, and a calibration changes no stage's work per frame",
    "fanout": "it times the chain, and a calibration changes no stage's work per frame",
    "run": "it times facesynth run against plain MediaPipe, and a calibration changes no "
    "stage's work per frame",
    "tracker": "it runs no F",
    "recording": "it runs no F",
    "face": "it runs no F",
    "drivers": "it runs no F",
}
#: Why a benchmark does not read an option, where saying which do is not enough.
WHY_NOT: Final[dict[str, dict[str, str]]] = {"calibration": NO_CALIBRATION}


def unread_options(args: argparse.Namespace) -> list[str]:
    """The options given (other than their defaults) that benchmark ``args.what`` does not
    read, each as ``--flag: bench WHAT does not read it (bench A, B do)``."""
    parser = argparse.ArgumentParser(add_help=False)
    add_bench_arguments(parser)
    problems = []
    for action in parser._actions:
        readers = READERS.get(action.dest)
        if readers is None or args.what in readers:
            continue
        if getattr(args, action.dest, action.default) != action.default:
            flag = action.option_strings[0] if action.option_strings else action.dest
            verb = "does" if len(readers) == 1 else "do"
            who = f"bench {', '.join(sorted(readers))} {verb}"
            why = WHY_NOT.get(action.dest, {}).get(args.what)
            problems.append(
                f"{flag}: bench {args.what} does not read it "
                + (f"({why}); {who}" if why else f"({who})")
            )
    if args.what != "robot":
        problems += [
            f"{flag}: bench {args.what} does not read it (bench robot does)"
            for flag in rig_flags_given(args, RIG)
        ]
    return problems


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
            "run",
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
        "--fps",
        type=float,
        default=30.0,
        help="chain, fanout, recording, drivers --emulated: frame rate (default 30)",
    )
    p.add_argument(
        "--openface-csv", metavar="PATH", help="chain: replay these landmarks instead of tracking"
    )
    p.add_argument(
        "--frames",
        type=int,
        help="tracker: frames to measure; robot: the video's first N frames (default: all); "
        "drivers --emulated: frames per driver (default 150); run: frames measured after a "
        "30-frame warm-up (default 300)",
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
        "through Zenoh's shared memory between processes on one host); fanout: one of them",
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
        help="chain: N interleaved runs of every variant (default 1; the goals ask for 3); "
        "fanout: N runs of each layout and count; run: N interleaved rounds of facesynth run "
        "and the plain MediaPipe script",
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
        help="robot: a simulated head to drive, repeatable, a bundled name, a head file or "
        "seed:N (a head generated from seed N) (default: every bundled head)",
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
        "--closed-loop",
        action="store_true",
        help="robot: also drive each learned --profile with T's loop closed through the "
        "head's camera, beside its open loop (the simulated heads in process, or with "
        "--driver the camera that measures the head)",
    )
    p.add_argument(
        "--planned",
        action="store_true",
        help="robot: also drive each learned --profile with its plan of the whole video "
        "(facesynth plan) played through C, beside its open loop (the simulated heads in "
        "process, or the head behind --driver)",
    )
    p.add_argument(
        "--learn-poses",
        type=int,
        metavar="N",
        help="robot: also learn a profile for each simulated head in process from N babbled "
        "poses (on the hardware profile with the head's servos, e.g. head16_hardware; the "
        "[learn] extra), drive the head with it as 'learned', and "
        "lead with the features the performer moves that the head moved while babbling",
    )
    p.add_argument(
        "--calibration",
        metavar="NAME|PATH",
        help="robot: the performer's calibration (facesynth calibrate: its neutral step, e.g. "
        "her face at rest) for her F and T, as run --calibration takes it (default: her "
        "neutral from her first second with a face); the other benchmarks refuse it",
    )
    p.add_argument(
        "--track", help="smoothing: a facesynth track file to measure tracking noise from"
    )
    p.add_argument(
        "--mode",
        default="client",
        metavar="A,B",
        help="chain: Zenoh modes of the services to compare, client and/or peer (default "
        "client); fanout: one of them",
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
        help="fidelity: profiles to measure (default: every shipped one); robot: more "
        "profiles to drive the heads with, as --profile",
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
        "mediapipe==0.10.21; see facesynth/app/bench/mediapipe_helper.py); run: run the "
        "plain MediaPipe script (facesynth/app/bench/plain_mediapipe.py) with it",
    )
    p.add_argument(
        "--mediapipe-task",
        metavar="PATH",
        help="tracker, run: the face_landmarker.task bundle for --mediapipe-python",
    )
    p.add_argument(
        "--minutes", type=float, default=10.0, help="recording: session length (default 10)"
    )
    # robot: a head outside this process, driven in real time through --driver (any servo
    # driver, with its options) and watched through --camera or --ros2-image-topic.
    add_rig_flags(
        p,
        {flag for action in p._actions for flag in action.option_strings},
        RIG,
        {
            "sensor": "robot: the camera watching a head outside this process (a live source)",
            "control": "robot: the servo driver of that head, with its options",
        },
    )
