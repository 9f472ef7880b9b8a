"""``facesynth learn``: babble a robot head in front of its camera, record a session, fit it.

::

    facesynth learn --profile head16_hardware --driver maestro --port /dev/ttyACM0 \\
        --camera http://192.168.1.20:8080/video.mjpg --poses 600 --out head.mcap

babbles (:mod:`facesynth.app.learn.shell`) into ``head.mcap`` (run it again to resume), then
reads the session into a :class:`~facesynth.app.learn.dataset.BabbleSet`, fits the self-model
and writes the learned profile (``--out-profile``; ``--no-fit`` skips it, ``--fit-only
SESSION`` does only that). A session that has not yet swept every servo is not fitted (one
line naming them and how to finish) unless ``--partial``, which keeps them at neutral.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time
from pathlib import Path
from typing import Any

import msgspec

from facesynth.app.learn.adaptive import AdaptivePlan
from facesynth.app.learn.babble_flags import babble_options, rig_configs
from facesynth.app.learn.core import BabbleOptions, Babbler, Budget, Streaming
from facesynth.app.learn.coverage import UnsweptError
from facesynth.app.learn.dataset import BabbleSet
from facesynth.app.learn.fit import FitOptions, fit_learned_profile, format_report
from facesynth.app.learn.models import MLP_MEMBERS
from facesynth.app.learn.plan import BabblePlan, Plan, PlanOptions
from facesynth.app.learn.plan_options import PlanChoice, choose
from facesynth.app.learn.progress import Progress
from facesynth.app.learn.session import (
    PLANS,
    Session,
    SessionFile,
    babble_set,
    check_profile,
    metadata,
    read_session,
)
from facesynth.app.learn.session_lag import session_lags
from facesynth.app.learn.shell import (
    RECORD_KEYS,
    BabbleShell,
    LearnResult,
    babble,
    on_embedded_router,
)
from facesynth.app.learn.stream import Trajectory
from facesynth.app.learn.sweeps import sweep_report
from facesynth.app.robot_rig import build_parts, preflight
from facesynth.app.wiring import StageParts, zenoh_options
from facesynth.runtime import keys
from facesynth.runtime.bus.zenoh_bus import endpoints
from facesynth.runtime.feature_names import NAMES
from facesynth.runtime.outputs import check_output
from facesynth.runtime.profiles import Profile, load_profile, save_learned_profile
from facesynth.runtime.service import run_async
from facesynth.services.control.drivers.registry import DRIVERS

log = logging.getLogger("facesynth.learn")

#: The robot's own rig, apart from any performer's.
DEFAULT_RIG = "self"


#: ``--plan stream``'s default budget (minutes): it is bounded by time, not by poses.
STREAM_MINUTES = 10.0


class LearnError(ValueError):
    """``facesynth learn`` options that cannot be used."""


def cmd_learn(args: argparse.Namespace) -> int:
    """``facesynth learn``."""
    if args.fit_only:
        if args.session:
            raise LearnError("give either --out (babble) or --fit-only SESSION (fit), not both")
        session = read_session(_existing(args.fit_only))
        profile = load_profile(args.profile or session.profile)
        check_profile(session, profile)
        out = _profile_out(args, Path(args.fit_only))
        used = choose(args, session.plan, session.seed, session.options, session.path)
        print(fit_session(session, profile, out, partial=args.partial, plan=used.base()))
        return 0
    if not args.session:
        raise LearnError("give the session file with --out SESSION.mcap")
    if not args.profile:
        raise LearnError("give the robot's hardware profile with --profile NAME")
    if args.minutes is not None and not args.minutes > 0:
        raise LearnError(f"--minutes must be positive, not {args.minutes:g}")
    poses = 600 if args.poses is None else args.poses
    if poses < 1:
        raise LearnError(f"--poses must be at least 1, not {poses}")
    if args.frame_every < 0:
        raise LearnError("--frame-every must be >= 0 (0: no frames)")
    rig = keys.check_name(args.rig or DEFAULT_RIG)
    profile = load_profile(args.profile)
    out = Path(args.session)
    resume = _resume(out, profile, args.seed)
    profile_out = None if args.no_fit else _profile_out(args, out)
    seed = resume.seed if resume is not None else (args.seed or 0)
    kind = plan_kind(args, resume)
    choice = choose(args, kind, seed, resume.options if resume is not None else None, out)
    plan_options = choice.base()
    plan = make_plan(choice, profile, resume)
    options = babble_options(args)
    first = resume.next_pose if resume is not None else 0
    budget: int | None = poses  # the session's poses to babble to; None: until the minutes end
    minutes = args.minutes
    if kind == "stream":  # the sweeps, then the stream until the minutes are spent
        if args.poses is not None:
            raise LearnError(
                "--plan stream babbles for --minutes (default 10), not a number of --poses: "
                "after the sweeps it learns from every frame"
            )
        budget, minutes = None, STREAM_MINUTES if minutes is None else minutes
    if budget is not None and first >= budget:
        print(f"{out} already holds {first} poses (--poses {poses}): nothing to babble")
    else:
        configs = rig_configs(args, out.with_suffix(".commands.jsonl"))
        if DRIVERS.build(configs["control"], profile).moves_hardware:
            run_async(preflight(configs["control"], profile))
        parts = build_parts(args.profile, rig, profile, configs)
        result = _babble(
            args,
            rig,
            profile,
            (choice, plan),
            options,
            first,
            (budget, minutes),
            seed,
            parts,
            resume,
        )
        rate = result.taken / (result.seconds / 60) if result.seconds > 0 else 0.0
        summary: dict[str, Any] = {
            "session": str(out),
            "poses": result.next_pose,
            "taken": result.taken,
            "skipped": result.skipped,
            "seconds": round(result.seconds, 1),
            "poses_per_minute": round(rate, 1),
            "interrupted": result.interrupted,
            # how the servos were known to be there: read back ("measured") or not
            "reached": result.reached,
        }
        if kind == "stream":
            summary["streamed_frames"] = result.streamed
        summary.update(_sweeps(out, profile))
        print(json.dumps(summary), flush=True)
        if result.interrupted:
            return 130
    if profile_out is None:
        return 0
    session = read_session(out)
    print(fit_session(session, profile, profile_out, partial=args.partial, plan=plan_options))
    return 0


def plan_kind(args: argparse.Namespace, resume: Session | None) -> str:
    """``--plan``, checked; a resumed session keeps the plan it was babbled with."""
    kind = getattr(args, "plan", None)
    if kind is not None and kind not in PLANS:
        raise LearnError(f"--plan must be one of {', '.join(PLANS)}, not {kind!r}")
    if resume is None:
        return kind or PLANS[0]
    if kind is not None and kind != resume.plan:
        raise LearnError(
            f"{resume.path} was babbled with --plan {resume.plan}: resume it with that plan "
            f"(or babble into a new file)"
        )
    return resume.plan


def make_plan(
    choice: PlanChoice,
    profile: Profile,
    resume: Session | None,
    inputs: tuple[str, ...] = NAMES,
) -> BabblePlan:
    """The plan ``choice`` names, made with the options of its kind; an adaptive one (which
    reads the faces' raw ``inputs``) resuming a session is told its poses' faces first."""
    if choice.kind != "adaptive":  # the stream plan streams after the fixed plan's sweeps
        return Plan(len(profile.servos), choice.base())
    plan = AdaptivePlan(tuple(s.name for s in profile.servos), list(inputs), choice.adaptive())
    if resume is not None:
        plan.replay({s.seq: s.features for s in resume.samples}, resume.next_pose)
        log.info("the adaptive plan was told the %d poses of %s", plan.observed, resume.path)
    return plan


def _sweeps(out: Path, profile: Profile) -> dict[str, Any]:
    """What the sweeps showed so far: dead servos, and each live one's dead band (the smallest
    normalized command below and above neutral that moved the face)."""
    report = sweep_report(read_session(out).samples, profile)
    if not report:
        return {}
    return {
        "dead": [r.servo for r in report if r.dead],
        "dead_band": {
            r.servo: [round(r.below, 2), round(r.above, 2)] for r in report if not r.dead
        },
    }


def fit_session(
    session: Session,
    profile: Profile,
    out: Path,
    *,
    partial: bool = False,
    plan: PlanOptions | None = None,
) -> str:
    """Read the session's poses into a BabbleSet, with the head's response lag measured on its
    one-servo moves (:mod:`facesynth.app.learn.session_lag`, in the fit's report), fit it and
    write the learned profile.

    A session that has not yet swept every servo is a :class:`LearnError` naming them and how
    to finish (``plan``: the babbling's options, for the poses the sweeps take), unless
    ``partial``."""
    if not session.samples:
        raise LearnError(f"{session.path} holds no babbling poses to fit")
    babble = babble_set(session.samples, profile, session_lags(session.path, session.samples))
    try:
        return fit(babble, profile, out, partial=partial)
    except UnsweptError as exc:
        sweeps = Plan(len(profile.servos), plan or PlanOptions()).sweep_poses
        raise LearnError(
            f"{session.path}: {exc}: resume the babbling to sweep them (the same learn "
            f"command with --out {session.path} and --poses {sweeps} or more), or fit what it "
            f"holds with --partial (they stay at neutral)"
        ) from None


def fit(babble: BabbleSet, profile: Profile, out: Path, *, partial: bool = False) -> str:
    """Fit the self-model on ``babble``, write the learned profile to ``out`` (atomically) and
    return the held-out report to print: the one call into the fitting
    (:mod:`facesynth.app.learn.fit`, which needs the ``learn`` extra). ``partial``: fit even
    if some servos were not swept yet (kept at neutral; logged)."""
    options = FitOptions(partial=partial, mlp_members=MLP_MEMBERS)
    learned = fit_learned_profile(babble, profile, options)
    report = learned.learned.report if learned.learned is not None else None
    if report is not None and (report.not_exercised or report.one_way):
        log.warning(
            "--partial: %d of %d servos not swept yet, kept at neutral in %s: %s",
            len(report.not_exercised) + len(report.one_way),
            len(profile.servos),
            out,
            ", ".join([*report.not_exercised, *report.one_way]),
        )
    # The learned profile is named after its file (robot.learned: robot), not the hardware's.
    name = out.name.removesuffix(".learned") or profile.name
    learned = msgspec.structs.replace(learned, name=name)
    written = save_learned_profile(learned, out)
    return f"{format_report(learned)}\nwrote {written}"


def _existing(path: str) -> Path:
    file = Path(path)
    if not file.is_file():
        raise LearnError(f"{file} does not exist or is not a file")
    return file


def _profile_out(args: argparse.Namespace, session: Path) -> Path:
    out = Path(args.out_profile) if args.out_profile else session.with_suffix(".learned")
    return check_output(out, "learned profile")


def _resume(out: Path, profile: Profile, seed: int | None) -> Session | None:
    if out.is_dir():
        raise LearnError(f"--out {out} is a directory, not a session file")
    if not out.exists():
        check_output(out, "session file")
        return None
    session = read_session(out)
    check_profile(session, profile)
    if seed is not None and seed != session.seed:
        raise LearnError(
            f"{out} was babbled with --seed {session.seed}: resume it with that seed "
            f"(or babble into a new file)"
        )
    log.info(
        "resuming %s: %d poses taken, from pose %d", out, len(session.samples), session.next_pose
    )
    return session


def _streaming(
    plan: tuple[PlanChoice, BabblePlan], profile: Profile, seed: int, resume: Session | None
) -> Streaming | None:
    """How ``--plan stream`` streams: after the sweeps, along the seed's trajectory, from where
    a resumed session's stream stopped."""
    choice, poses = plan
    if choice.kind != "stream" or not isinstance(poses, Plan):
        return None
    trajectory = Trajectory(len(profile.servos), seed)
    return Streaming(poses.sweep_poses, trajectory, resume.streamed_s if resume else 0.0)


def _babble(
    args: argparse.Namespace,
    rig: str,
    profile: Profile,
    plan: tuple[PlanChoice, BabblePlan],
    options: BabbleOptions,
    first: int,
    budget: tuple[int | None, float | None],
    seed: int,
    parts: dict[str, StageParts],
    resume: Session | None,
) -> LearnResult:
    """Babble until the session holds ``budget``'s poses or its minutes are spent (either may
    be ``None``: no bound), from pose ``first`` of the plan."""
    poses, minutes = budget
    out = Path(args.session)
    out.parent.mkdir(parents=True, exist_ok=True)
    listen = endpoints(args.listen) or ["tcp/127.0.0.1:0"]
    zenoh = zenoh_options(args, default_mode="router")
    zenoh.connect = endpoints(args.connect)
    record = [*RECORD_KEYS] if args.frame_every else [k for k in RECORD_KEYS if k != "input"]

    async def main() -> LearnResult:
        now = time.monotonic()
        until = now + minutes * 60 if minutes is not None else None
        until_ns = round(until * 1e9) if until is not None else None
        stream = _streaming(plan, profile, seed, resume)
        babbler = Babbler(
            profile,
            plan[1],
            start=first,
            budget=Budget(poses=poses, until_ns=until_ns),
            options=options,
            stream=stream,
        )
        progress = Progress(sys.stderr, first=first, total=poses, started_s=now, until_s=until)
        shell = BabbleShell(babbler, seed=seed, progress=progress, on_neutral=lambda: None)
        meta = metadata(rig, profile, seed, record, plan[0].kind, plan[0].metadata())
        meta["frame_every"] = str(args.frame_every)
        session = SessionFile(out, meta, resume)
        return await on_embedded_router(
            listen,
            zenoh,
            rig,
            lambda bus: babble(
                bus,
                rig,
                parts,
                shell,
                session,
                frame_every=args.frame_every,
                record=record,
                stats_interval=args.stats_interval,
            ),
        )

    return run_async(main())
