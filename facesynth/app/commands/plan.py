"""``facesynth plan VIDEO --profile ROBOT.learned --out PLAN.mcap``: a recorded performance
planned for a learned robot, offline (:mod:`facesynth.app.plan`).

The video is tracked in process (the ``full`` model, blendshapes on, F's neutral from her
first second or ``--calibration``'s neutral step, as ``bench robot`` tracks a performer); the
servo commands that follow the whole performance best through the robot's self-model are
written as a recording of ``…/servo_commands`` (``--robot NAME``: of that robot's
``…/servo_commands/NAME`` on a multi-robot rig), which ``facesynth replay PLAN.mcap --from
servo_commands`` plays to the robot's control service. One JSON line says what was planned.

With ``--driver NAME [--port PORT] --camera CAMERA`` (any servo driver and camera source with
their options, as ``facesynth learn`` takes them: :mod:`facesynth.app.learn.babble_flags`) the
plan is rehearsed on the robot (:mod:`facesynth.app.plan.rehearsal`): ``--rounds`` times, the
robot is posed at the planned frames (every ``--look-every``-th), its settled faces read
through its camera, and what the self-model got wrong corrected for; the round the robot
showed best is written.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import TYPE_CHECKING

from facesynth.app.command_registry import Command
from facesynth.app.learn.babble_flags import (
    add_babble_flags,
    add_rig_flags,
    babble_options,
    camera_given,
    driver_given,
    rig_configs,
    rig_flags_given,
)
from facesynth.runtime import keys
from facesynth.runtime.outputs import check_output

#: ``--look-every``'s default: on the whole sample video, 150 poses a round (1 min 40 s on
#: simhead16 through its camera).
LOOK_EVERY = 3

if TYPE_CHECKING:
    import msgspec

    from facesynth.app.plan.performance import RobotLook
    from facesynth.runtime.profiles import Profile


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
    configs = None  # the robot's rig, checked before anything is loaded
    if driver_given(args):
        configs = rig_configs(args, out.with_suffix(".commands.jsonl"))
    profile = load_profile(args.profile)
    self_model(profile)
    look = None if configs is None else _rehearsal(args, profile, out, configs)
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
        look=look,
        rounds=args.rounds or 1,
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
    if look is not None:
        summary.update(
            {
                "robot_rho_rounds": [round(rho, 3) for rho in plan.robot_rho],
                "kept_round": plan.kept_round,
                "rehearsal_stopped": plan.stopped,
            }
        )
    print(json.dumps(summary))
    return 130 if plan.stopped else 0


def _rehearsal(
    args: argparse.Namespace, profile: Profile, out: Path, configs: dict[str, msgspec.Struct]
) -> RobotLook:
    """The robot of ``configs`` (its camera, tracker and servo driver), to rehearse the plan on
    (its servo board opened once)."""
    from facesynth.app.plan.rehearsal import RobotRehearsal, round_path
    from facesynth.app.robot_rig import preflight
    from facesynth.runtime.service import run_async
    from facesynth.services.control.drivers.registry import DRIVERS

    for path in (round_path(out, k) for k in range(args.rounds + 1)):
        if path.exists():
            raise ValueError(f"{path} exists (a rehearsal's round is never written over)")
    if DRIVERS.build(configs["control"], profile).moves_hardware:
        run_async(preflight(configs["control"], profile))
    return RobotRehearsal(
        profile,
        args.profile,
        configs,
        out,
        babble_options(args),
        look_every=args.look_every or LOOK_EVERY,
        frame_every=args.frame_every,
    )


def _check_options(args: argparse.Namespace) -> None:
    keys.check_name(args.rig)
    if args.robot is not None:
        keys.check_name(args.robot, "robot")
    for name in ("amplitude", "smooth", "lead"):
        value = getattr(args, name)
        if not 0 <= value <= 100:
            raise ValueError(f"--{name} must be within 0..100 (got {value:g})")
    if not driver_given(args):
        given = rig_flags_given(args)
        given += [
            f"--{n.replace('_', '-')}"
            for n in ("rounds", "look_every")
            if getattr(args, n) is not None
        ]
        if given:
            raise ValueError(
                f"{given[0]} is for a rehearsal on the robot, which needs --driver and --camera"
            )
        return
    if not camera_given(args):
        raise ValueError("a rehearsal on the robot needs both --driver and --camera")
    from facesynth.app.plan.sequence_rehearsed import REHEARSALS

    args.rounds = REHEARSALS if args.rounds is None else args.rounds
    if args.rounds < 1:
        raise ValueError(f"--rounds must be at least 1 (got {args.rounds})")
    if args.look_every is not None and args.look_every < 1:
        raise ValueError(f"--look-every must be at least 1 (got {args.look_every})")
    if args.frame_every < 0:
        raise ValueError("--frame-every must be >= 0 (0: no frames)")


HELP = (
    "plan a recorded performance for a learned robot offline: the servo commands that follow "
    "the whole video best through its self-model, as a recording replay plays to the robot"
)


def _arguments(p: argparse.ArgumentParser) -> None:
    from facesynth.app.plan.sequence import AMPLITUDE, SMOOTH
    from facesynth.app.plan.sequence_rehearsed import REHEARSALS

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

    robot = p.add_argument_group(
        "rehearsal on the robot",
        "pose the robot at the planned frames, read its settled faces through its camera and "
        "correct what the self-model got wrong (each round recorded beside the plan as "
        "PLAN.round<K>.mcap)",
    )
    robot.add_argument(
        "--rounds",
        type=int,
        help=f"rehearsals after the robot shows the plan (default {REHEARSALS})",
    )
    robot.add_argument(
        "--look-every",
        type=int,
        metavar="K",
        help="pose every Kth planned frame only (and the last), what the self-model got wrong "
        f"interpolated between: a round takes a Kth of the time (default {LOOK_EVERY})",
    )
    add_babble_flags(robot)
    # The robot's camera, the tracker on its frames and its servo driver: every plugin's
    # flags, as facesynth learn takes them (``--driver NAME --port PORT --camera URL``, …).
    add_rig_flags(p, {"--out", "--profile"})


COMMANDS = (Command("plan", HELP, cmd_plan, _arguments),)
