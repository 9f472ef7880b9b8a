"""A recorded performance planned for a learned robot: its servo commands, as a recording.

:func:`plan_performance` takes F's output for every frame of a performer's video and a learned
profile with a ``poly_ridge`` self-model. T's targets and commands for each frame
(:func:`~facesynth.app.plan.targets.translate`) start the search of
:func:`~facesynth.app.plan.sequence.sequence_commands`: the commands whose self-model faces
follow the whole performance best by the likeness measure (correlation per feature, her
amplitude kept, no jumps between frames), over the features the robot can show
(:func:`~facesynth.runtime.profiles.learned.shown_inputs`) that the performance moves. Each
frame's commands become pulses within the profile's limits (the learned servos within their
responsive ranges, the dead ones at neutral); a frame without a target (no face, or F's
neutral not yet known) holds the profile's neutral, and the jump from it into the first
planned frame counts as any other.

:func:`write_plan` writes them as ``…/servo_commands`` samples at the video's media times, a
recording that ``facesynth replay PLAN --from servo_commands`` publishes to a robot's control
service (or runs through C with ``--graph``), which clamps them and limits their speed as it
does T's.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from facesynth.app.plan.sequence import AMPLITUDE, ITERATIONS, SMOOTH, sequence_commands
from facesynth.app.plan.sequence_rehearsed import DAMPING, REHEARSALS, rehearsed_commands
from facesynth.app.plan.targets import standardized, translate
from facesynth.runtime import codec, keys
from facesynth.runtime.profiles import Profile
from facesynth.runtime.profiles.learned import PolyRidge, command_range, shown_inputs, unpack
from facesynth.schemas.messages import Features, ServoCommands
from facesynth.services.translator.learned import LearnedTargets
from facesynth.services.translator.self_model_face import PolyFace

__all__ = [
    "MIN_SPREAD",
    "SENDER",
    "PlanError",
    "PlannedPerformance",
    "RobotLook",
    "plan_performance",
    "pulses",
    "self_model",
    "write_plan",
]

#: A feature whose targets spread less than this share of the robot's own spread (its
#: standard deviation while babbling) is not followed: too little of it to correlate.
MIN_SPREAD = 0.05
#: The ``sender`` of a plan's commands.
SENDER = "plan"


#: A robot shown a plan (``plan --camera``): the planned frames' commands (frames × the
#: learned outputs, normalized) → its settled faces (frames × the learned inputs, raw; a row
#: of NaN: not looked at or not seen), or None: the rehearsal was stopped.
RobotLook = Callable[[np.ndarray], np.ndarray | None]


class PlanError(ValueError):
    """A performance that cannot be planned (the message says why, in one line)."""


@dataclass(frozen=True)
class PlannedPerformance:
    """A planned performance: per frame, its media time, whether F saw her face, and every
    servo's pulse (µs, within its limits); how many frames had a target; the features
    followed; the mean correlation with her targets over those features, through the
    self-model, of T's own commands (``rho_t``) and of the plan (``rho_plan``), and the
    search's iterations. Rehearsed on the robot: the mean correlation in what it showed,
    round by round (``robot_rho``, the first the plan before any rehearsal), the round kept
    (``kept_round``: the one the robot showed best) and whether the rehearsal was stopped."""

    profile: str
    t_media_ns: list[int]
    faces: list[bool]
    positions: list[dict[str, float]]
    planned_frames: int
    followed: list[str]
    rho_t: float
    rho_plan: float
    iterations: int
    robot_rho: list[float] = field(default_factory=list)
    kept_round: int | None = None
    stopped: bool = False

    def commands(self) -> list[ServoCommands]:
        """The plan as servo commands, one per frame (``sender`` :data:`SENDER`, not aged)."""
        return [
            ServoCommands(
                seq=index,
                t_capture_ns=t_ns,
                t_media_ns=t_ns,
                face=face,
                profile=self.profile,
                positions=positions,
                sender=SENDER,
                sender_seq=index + 1,
            )
            for index, (t_ns, face, positions) in enumerate(
                zip(self.t_media_ns, self.faces, self.positions, strict=True)
            )
        ]


def self_model(profile: Profile) -> PolyRidge:
    """The ``poly_ridge`` self-model a plan of ``profile`` goes through, or a
    :class:`PlanError` saying why there is none (checked before a video is tracked)."""
    learned = profile.learned
    if learned is None:
        raise PlanError(f"profile {profile.name} is not learned (facesynth learn writes one)")
    if not isinstance(learned.forward, PolyRidge):
        raise PlanError(f"profile {profile.name} has no poly_ridge self-model to plan through")
    return learned.forward


def plan_performance(
    profile: Profile,
    features: Sequence[Features],
    *,
    amplitude: float = AMPLITUDE,
    smooth: float = SMOOTH,
    iterations: int = ITERATIONS,
    lead_frames: int = 0,
    look: RobotLook | None = None,
    rounds: int = REHEARSALS,
) -> PlannedPerformance:
    """The commands of ``profile`` for the performance F saw as ``features`` (one per video
    frame, in order; see the module), each frame's sent ``lead_frames`` frames early (against
    the head's own lag; the last frame's held at the end). With ``look`` (the robot itself),
    the plan is rehearsed ``rounds`` times (:func:`~facesynth.app.plan.sequence_rehearsed.
    rehearsed_commands`, from the plan found through the self-model, damped by
    :data:`~facesynth.app.plan.sequence_rehearsed.DAMPING`) and the round the robot showed best is
    kept. :class:`PlanError` for a profile that is not learned or has no ``poly_ridge``
    self-model, fewer than 3 frames with a target, a performance that moves
    none of the features the robot can show, a negative lead or fewer than 1 round."""
    if lead_frames < 0:
        raise PlanError(f"the lead must be 0 frames or more (got {lead_frames})")
    if look is not None and rounds < 1:
        raise PlanError(f"a rehearsal takes 1 round or more (got {rounds})")
    forward = self_model(profile)
    learned = profile.learned
    assert learned is not None  # (self_model checked it)
    wanted, _, planned = translate(profile, features)
    frames, targets = standardized(learned, wanted)
    if len(frames) < 3:
        raise PlanError(
            f"{len(frames)} frames with her face and a neutral (F's first second is its "
            "neutral); a plan needs 3 or more"
        )
    shown = set(shown_inputs(learned))
    spread = targets.std(axis=0)
    columns = [
        i
        for i, name in enumerate(learned.inputs)
        if name in shown and spread[i] >= MIN_SPREAD and np.ptp(targets[:, i]) > 0
    ]
    if not columns:
        raise PlanError("the performance moves none of the features the robot can show")
    low, high = command_range(learned)
    model = PolyFace(forward)
    before = np.zeros(len(low)) if frames[0] > 0 else None  # from the neutral it held
    found = sequence_commands(
        model,
        targets,
        np.array([planned[i] for i in frames]),
        low,
        high,
        features=columns,
        amplitude=amplitude,
        smooth=smooth,
        iterations=iterations,
        before=before,
    )
    commands, rehearsed = found.commands, None
    if look is not None:
        mean, scale = unpack(learned.input_mean), unpack(learned.input_scale)

        def standardized_look(u: np.ndarray) -> np.ndarray | None:
            seen = look(u)
            return None if seen is None else (seen - mean) / scale

        rehearsed = rehearsed_commands(
            model,
            standardized_look,
            targets,
            found.commands,
            low,
            high,
            features=columns,
            rounds=rounds,
            amplitude=amplitude,
            smooth=smooth,
            iterations=iterations,
            before=before,
            damping=DAMPING,
        )
        if rehearsed.commands:
            commands = rehearsed.best
    neutral = {spec.name: spec.neutral_us for spec in profile.servos}
    positions = [dict(neutral) for _ in features]
    for index, frame in zip(frames, pulses(profile, commands), strict=True):
        positions[index].update(frame)
    faces = [bool(f.face) for f in features]
    if lead_frames:
        last = len(features) - 1
        positions = [dict(positions[min(i + lead_frames, last)]) for i in range(last + 1)]
        faces = [faces[min(i + lead_frames, last)] for i in range(last + 1)]
    return PlannedPerformance(
        profile=profile.name,
        t_media_ns=[f.t_media_ns for f in features],
        faces=faces,
        positions=positions,
        planned_frames=len(frames),
        followed=[learned.inputs[i] for i in columns],
        rho_t=found.start_rho,
        rho_plan=found.rho,
        iterations=found.iterations,
        robot_rho=[] if rehearsed is None else rehearsed.shown_rho,
        kept_round=(
            None if rehearsed is None or not rehearsed.commands else int(np.argmax(rehearsed.shown))
        ),
        stopped=rehearsed is not None and rehearsed.stopped,
    )


def pulses(profile: Profile, commands: np.ndarray) -> list[dict[str, float]]:
    """Each frame's normalized commands of the learned outputs (frames × outputs) as pulses
    (µs) by servo, each within its servo's limits (the servos a learned profile does not
    drive are not in them)."""
    servo = LearnedTargets(profile, {})
    return [dict(zip(servo.outputs, servo.positions(u).tolist(), strict=True)) for u in commands]


def write_plan(
    plan: PlannedPerformance,
    out: str | Path,
    *,
    rig: str = "default",
    robot: str | None = None,
    source: str = "",
    overwrite: bool = False,
) -> int:
    """Write ``plan`` as a recording of the rig's ``…/servo_commands`` (with ``robot``, of
    that robot's ``…/servo_commands/<robot>`` of a multi-robot rig); the number of
    commands written. The recording's own errors
    (:class:`~facesynth.app.recording.writer.RecordingFileError`) for a file that exists or
    a folder that does not."""
    from facesynth.app.recording.layout import LAYOUT_VERSION, Layout
    from facesynth.app.recording.writer import SessionWriter

    key = keys.stage_key(rig, "servo_commands", robot)
    frames = len(plan.t_media_ns)
    seconds = plan.t_media_ns[-1] / 1e9 if frames > 1 else 0.0
    metadata = {
        "rig": rig,
        "keys": "servo_commands",
        "source": f"plan:{source}",
        "fps": f"{(frames - 1) / seconds:g}" if seconds > 0 else "0",
        "layout": LAYOUT_VERSION,
        "profile": plan.profile,
        **({"robot": robot} if robot else {}),
    }
    writer = SessionWriter(out, metadata=metadata, fsync=False, overwrite=overwrite)
    layout = Layout()
    try:
        for command in plan.commands():
            payload = codec.encode(command)
            for entry in layout.entries(key, payload, command.t_media_ns, command.seq):
                writer.write(entry)
    finally:
        writer.close()
    return frames
