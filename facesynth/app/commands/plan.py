"""``facesynth plan VIDEO --profile ROBOT.learned --out PLAN.mcap``: a recorded performance
planned for a learned robot, offline (:mod:`facesynth.app.plan`).

The video is tracked in process (the ``full`` model, blendshapes on, F's neutral from her
first second or ``--calibration``'s neutral step, as ``bench robot`` tracks a performer); the
servo commands that follow the whole performance best through the robot's self-model are
written as a recording of ``…/servo_commands`` (``--robot NAME``: of that robot's
``…/servo_commands/NAME`` on a multi-robot rig), which ``facesynth replay PLAN.mcap --from
servo_commands`` plays to the robot's control service. One JSON line says what was planned.
"""

from __future__ import annotations

import argparse
import json
import time

from facesynth.app.command_registry import Command
from facesynth.runtime import keys
from facesynth.runtime.outputs import check_output


def cmd_plan(args: argparse.Namespace) -> int:
    """``facesynth plan VIDEO --profile ROBOT.learned --out PLAN.mcap``."""
    from facesynth.app.engine.performer import track_video
    from facesynth.app.plan.performance import plan_performance, self_model, write_plan
    from facesynth.app.recording.extra import need_record_extra
    from facesynth.runtime.calibration import load_calibration
    from facesynth.runtime.profiles import load_profile

    need_record_extra()
    _check_options(args)
    out = check_output(args.out, "plan file")
    if out.exists():
        raise ValueError(f"{args.out} exists (a plan is never written over)")
    profile = load_profile(args.profile)
    self_model(profile)
    calibration = None if args.calibration is None else load_calibration(args.calibration)
    tracked = track_video(args.video, frames=args.frames, calibration=calibration)
    planning = time.monotonic()
    out.parent.mkdir(exist_ok=True)  # the file's own folder (check_output allows it missing)
    plan = plan_performance(
        profile,
        tracked.features,
        amplitude=args.amplitude,
        smooth=args.smooth,
        lead_frames=round(args.lead * tracked.fps),
    )
    written = write_plan(plan, args.out, rig=args.rig, robot=args.robot, source=args.video)
    summary = {
        "out": args.out,
        "profile": plan.profile,
        "frames": written,
        "planned_frames": plan.planned_frames,
        "features_followed": len(plan.followed),
        "self_model_rho_t": round(plan.rho_t, 3),
        "self_model_rho_plan": round(plan.rho_plan, 3),
        "iterations": plan.iterations,
        "tracking_s": round(tracked.seconds, 1),
        "planning_s": round(time.monotonic() - planning, 1),
    }
    print(json.dumps(summary))
    return 0


def _check_options(args: argparse.Namespace) -> None:
    keys.check_name(args.rig)
    if args.robot is not None:
        keys.check_name(args.robot, "robot")
    for name in ("amplitude", "smooth", "lead"):
        value = getattr(args, name)
        if not 0 <= value <= 100:
            raise ValueError(f"--{name} must be within 0..100 (got {value:g})")


HELP = (
    "plan a recorded performance for a learned robot offline: the servo commands that follow "
    "the whole video best through its self-model, as a recording replay plays to the robot"
)


def _arguments(p: argparse.ArgumentParser) -> None:
    from facesynth.app.plan.sequence import AMPLITUDE, SMOOTH

    p.add_argument("video", help="the performer's video")
    p.add_argument(
        "--profile",
        required=True,
        help="a learned profile with a self-model (NAME or PATH.learned; facesynth learn)",
    )
    p.add_argument("--out", required=True, metavar="PLAN.mcap", help="the plan (a new file)")
    p.add_argument(
        "--calibration",
        help="the performer's calibration (its neutral step; default: her first second)",
    )
    p.add_argument("--frames", type=int, help="plan the first N frames only (default: all)")
    p.add_argument(
        "--amplitude",
        type=float,
        default=AMPLITUDE,
        help=f"weight of her amplitude against the correlation (default {AMPLITUDE:g})",
    )
    p.add_argument(
        "--smooth",
        type=float,
        default=SMOOTH,
        help=f"weight against jumps between frames (default {SMOOTH:g})",
    )
    p.add_argument(
        "--lead",
        type=float,
        default=0.0,
        metavar="S",
        help="send each frame's commands this many seconds early, against the head's own "
        "lag (facesynth learn reports it; default 0)",
    )
    p.add_argument("--rig", default="default", help="the rig whose …/servo_commands it is on")
    p.add_argument(
        "--robot",
        metavar="NAME",
        help="a multi-robot rig's robot: the plan is on its …/servo_commands/NAME "
        "(its control service's --robot)",
    )


COMMANDS = (Command("plan", HELP, cmd_plan, _arguments),)
