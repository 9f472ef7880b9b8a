"""``facesynth bench robot``: its options checked, the heads opened, the result printed."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from pathlib import Path

from facesynth.app.engine.robot_loop import Head, RobotError
from facesynth.app.learn.babble_flags import camera_given, driver_given, rig_flags_given
from facesynth.app.wiring import OptionError
from facesynth.runtime.atomic import write_atomic
from facesynth.runtime.calibration import Calibration, load_calibration
from facesynth.runtime.outputs import check_output
from facesynth.runtime.profiles import Profile

from .arguments import RIG
from .robot import DEFAULT_PROFILES, bench_robot, track_performer
from .robot_outside import bench_outside
from .robot_report import format_robot, robot_json
from .robot_variants import Runner


def simulated_heads(names: list[str] | None) -> tuple[list[str], Callable[[str], Head]]:
    """The heads to drive (default: every bundled simulated head), each checked now, and a
    function building a fresh one by name."""
    from facesynth.app.simhead import SimHead, head_names, load_head

    chosen = names or head_names()
    configs = {name: load_head(name) for name in chosen}  # a clear error before any tracking
    return chosen, lambda name: SimHead(configs[name])


def profiles_of(args: argparse.Namespace) -> list[str]:
    """``--profile`` (repeated) and ``--profiles A,B``, in order; default the hand-written."""
    chosen = list(args.profile or [])
    chosen += [p.strip() for p in (args.profiles or "").split(",") if p.strip()]
    return chosen or list(DEFAULT_PROFILES)


def performer_calibration(name: str | None) -> Calibration | None:
    """``--calibration NAME|PATH``: the performer's calibration, checked before any tracking
    (None: F takes her neutral from her first second with a face)."""
    if name is None:
        return None
    try:
        return load_calibration(name)
    except ValueError as exc:
        raise RobotError(f"--calibration: {exc}") from None


def bench_robot_command(args: argparse.Namespace) -> int:
    """Every profile on every simulated head in process, or (``--driver``, ``--camera`` or
    ``--ros2-image-topic``) on a head outside it in real time; a table (or ``--json``) on
    stdout."""
    from facesynth.app.data import sample_video
    from facesynth.runtime.profiles import load_profile

    if args.frames is not None and args.frames < 1:
        raise OptionError("--frames must be at least 1")
    if args.json not in (None, "-"):
        check_output(Path(args.json), "JSON")  # before any tracking
    profiles = profiles_of(args)
    loaded: dict[str, Profile] = {}
    for name in profiles:
        try:
            loaded[name] = load_profile(name)  # before any tracking
        except ValueError as exc:
            raise RobotError(f"--profile {name}: {exc}") from None
    calibration = performer_calibration(getattr(args, "calibration", None))
    live = driver_given(args) or camera_given(args)
    ways = [flag for flag in ("closed_loop", "planned") if getattr(args, flag, False)]
    for flag in ways:
        _check_variant(flag, loaded, args.learn_poses is not None)
    if args.learn_poses is not None:
        _check_learn(args.learn_poses, live)

    def progress(what: str) -> None:
        print(f"bench robot: {what}", file=sys.stderr, flush=True)

    if live:
        chosen = [loaded[name] for name in profiles]  # loaded once, above
        result = bench_outside(args, chosen, ways, progress, calibration)
    else:
        stray = rig_flags_given(args, RIG)
        if stray:
            raise OptionError(f"{stray[0]} goes with --driver (a head outside this process)")
        heads, open_head = simulated_heads(args.head)
        learn = _learner(args.learn_poses) if args.learn_poses is not None else None
        progress("tracking the performer")
        performance = track_performer(
            args.video or str(sample_video()), frames=args.frames, calibration=calibration
        )
        if ways:
            from .robot_variants import bench_variants

            result = bench_variants(
                performance,
                heads,
                profiles,
                open_head,
                dict(_variant(flag) for flag in ways),
                progress=progress,
                learn=learn,
            )
        else:
            result = bench_robot(
                performance, heads, profiles, open_head, progress=progress, learn=learn
            )
    text = json.dumps(robot_json(result), indent=2)
    if args.json == "-":
        print(text)
        return 0
    if args.json:
        write_atomic(args.json, text + "\n", mode=0o644)
    print(format_robot(result))
    return 0


def _check_variant(flag: str, profiles: dict[str, Profile], learning: bool) -> None:
    """``--closed-loop`` / ``--planned``: a learned profile to run that way (one of
    ``profiles``, loaded by name, or one ``--learn-poses`` learns), each learned one with the
    ``poly_ridge`` self-model both go through (checked before the performer is tracked)."""
    from facesynth.runtime.profiles.learned import PolyRidge

    option = "--" + flag.replace("_", "-")
    verb = {"closed_loop": "closes the loop on", "planned": "plays plans to"}[flag]
    learned = [(name, p.learned) for name, p in profiles.items() if p.learned is not None]
    if not learning and not learned:
        raise OptionError(
            f"{option} needs a learned --profile (e.g. runs/head.learned) or --learn-poses "
            f"(it {verb} learned profiles only)"
        )
    for name, mapping in learned:
        if not isinstance(mapping.forward, PolyRidge):
            raise OptionError(
                f"{option}: profile {name} has no poly_ridge self-model (it {verb} learned "
                "profiles through theirs; facesynth learn writes one)"
            )


def _variant(flag: str) -> tuple[str, Runner]:
    """The suffix and runner of ``--closed-loop`` or ``--planned``."""
    if flag == "closed_loop":
        from .robot_closed import CLOSED_SUFFIX, closed_runner

        return CLOSED_SUFFIX, closed_runner()
    from .robot_planned import PLANNED_SUFFIX, run_planned

    return PLANNED_SUFFIX, run_planned


def _check_learn(poses: int, live: bool) -> None:
    """``--learn-poses N``: simulated heads in process, enough poses, scikit-learn."""
    from facesynth.app.learn.inprocess import MIN_POSES
    from facesynth.app.learn.models import require_sklearn

    if live:
        raise OptionError(
            "--learn-poses babbles the simulated heads in process; with --driver, learn with "
            "facesynth learn and pass the result as --profile"
        )
    if poses < MIN_POSES:
        raise OptionError(f"--learn-poses must be at least {MIN_POSES} (got {poses})")
    require_sklearn()  # before any tracking


def _learner(poses: int) -> Callable[[str], list[Profile]]:
    """A profile learned for a simulated head (by name) from ``poses`` babbled poses of it,
    on the hardware profile that has its servos
    (:func:`~facesynth.app.learn.inprocess.hardware_for`)."""
    from facesynth.app.learn.inprocess import learn_simhead

    def learn(head: str) -> list[Profile]:
        return [learn_simhead(head, poses)]

    return learn
