"""Babble a simulated head in process, faster than real time, and measure a learned profile.

The head (:mod:`facesynth.app.simhead`) is commanded a pose, left to settle (its slew and lag
are over well within :data:`SETTLE_NS`), rendered, tracked with the ``full`` model for a few
frames and read by F with the head at rest as its neutral: what ``facesynth learn`` sees
through the Maestro pty and the MJPEG camera, without the real-time pacing (:class:`SimBabbler`,
:func:`babble`). Used to compare babbling plans and fits on the same pose budget (``python -m
facesynth.app.learn.compare``), by ``bench robot --learn-poses`` and by the tests of the fit on
a simulated head.

:func:`babble_simhead` babbles uniform random poses of a head (a neutral every
``neutral_every`` poses, optionally after the sweeps of ``facesynth learn``'s plan) on the
hardware profile that has its servos (:func:`hardware_for`); :func:`learn_simhead` fits a
learned profile on such a babbling (:func:`facesynth.app.learn.fit.fit_learned_profile`, the
``[learn]`` extra). The babbling has no timing data (each pose is looked at settled): the
head's response lag is probed apart (:func:`probe_lags`: steps of each servo followed frame by
frame, as a session's one-servo moves are in :mod:`facesynth.app.learn.session_lag`).

:func:`held_out_error` measures a learned profile's inverse model on poses it was not fitted
on (a separate babbling, e.g. uniform random poses): the command error, raw and effective, as
the fit's report gives it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING

import msgspec
import numpy as np

from facesynth.app.learn.core import BabbleOptions, paced_speed
from facesynth.app.learn.dataset import BabbleSet
from facesynth.app.learn.lag import Transition, servo_lags
from facesynth.app.learn.stream import Streaming, Trajectory
from facesynth.runtime.feature_names import NAMES
from facesynth.runtime.frames import encode_frame
from facesynth.runtime.profiles import Profile, available_profiles, load_profile
from facesynth.runtime.profiles.learned import command_range, unpack
from facesynth.runtime.profiles.learned_predict import predictor

if TYPE_CHECKING:
    from facesynth.app.simhead import HeadConfig
    from facesynth.schemas.messages import Features

#: The head's slew and settle lag are over well within this.
SETTLE_NS = 1_500_000_000
#: The babbler's pace (a fraction of each servo's ``max_speed``), as ``facesynth learn`` has it.
PACE = BabbleOptions().pace
FRAME_NS = 33_333_333
#: Frames the face is followed for after a probing step (the slowest bundled skin, 0.15 s,
#: and slew, 1,500 µs/s, are over within them).
PROBE_FRAMES = 30
#: The probing steps' size (normalized command, each way from neutral).
PROBE_STEP = 0.5


class SimBabbler:
    """A simulated head with its camera, tracker and F: :meth:`look` at a pose's face."""

    def __init__(self, profile: Profile, head: str = "simhead16", frames: int = 2) -> None:
        from facesynth.app.simhead import SimHead, load_head
        from facesynth.services.features.core import FeatureProcessor
        from facesynth.services.points.backends.tracker import TrackerBackend, TrackerConfig

        self.profile = profile
        self.frames = frames
        self._sim = SimHead(load_head(head))
        self._backend = TrackerBackend(TrackerConfig(model="full"))
        self._processor = FeatureProcessor(neutral_seconds=0.1)
        specs = profile.servos
        self._neutral = np.array([s.neutral_us for s in specs])
        self._up = np.array([s.max_us - s.neutral_us for s in specs])
        self._down = np.array([s.neutral_us - s.min_us for s in specs])
        self._seq = 0
        self.look(np.zeros(len(specs)), 6)  # F's neutral: the head at rest

    def pulses(self, u: np.ndarray) -> np.ndarray:
        """Normalized commands as pulse widths (within each servo's limits)."""
        u = np.clip(u, -1.0, 1.0)
        out: np.ndarray = self._neutral + np.where(u >= 0, u * self._up, u * self._down)
        return out

    def look(self, u: np.ndarray, frames: int | None = None) -> np.ndarray:
        """The face (``Features.raw`` over :data:`NAMES`, NaN where absent) at pose ``u``."""
        sim = self._sim
        self._command(self.pulses(u))
        sim.step(sim.t_ns + SETTLE_NS)
        image = sim.render()
        face = np.full(len(NAMES), np.nan)
        for _ in range(frames or self.frames):
            sim.step(sim.t_ns + FRAME_NS)
            face = self._track(image)
        return face

    def _track(self, image: np.ndarray | None = None) -> np.ndarray:
        """The face in ``image`` (default: the head rendered now), tracked and read by F as
        the camera's next frame."""
        sim = self._sim
        frame = encode_frame(
            sim.render() if image is None else image,
            seq=self._seq,
            t_capture_ns=sim.t_ns,
            t_media_ns=sim.t_ns,
            encoding="raw",
        )
        self._seq += 1
        return self._read(self._processor.process(self._backend.process(frame)))

    @staticmethod
    def _read(features: Features | None) -> np.ndarray:
        raw = features.raw if features and features.face and features.neutral_ready else {}
        return np.array([raw.get(name, np.nan) for name in NAMES], dtype=np.float64)

    def follow(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(times, faces)``: the face frame by frame (:data:`PROBE_FRAMES` frames, times in
        s from the command) as the head, settled where it was, goes to pose ``u`` commanded
        as a step: a transition of :mod:`facesynth.app.learn.lag` (settle with :meth:`look`
        for its face after)."""
        sim = self._sim
        self._command(self.pulses(u))
        start, faces = sim.t_ns, []
        for index in range(PROBE_FRAMES):
            sim.step(start + index * FRAME_NS)
            faces.append(self._track())
        return np.arange(PROBE_FRAMES) * FRAME_NS / 1e9, np.array(faces)

    def stream(
        self,
        trajectory: Trajectory,
        seconds: float,
        every: int = 3,
        offset_s: float = 0.0,
        pace: float = PACE,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(t_ns, pulses, faces)``: the head commanded along ``trajectory`` (from
        ``offset_s`` into it) at the camera's rate for ``seconds`` (the command changing every
        frame, as ``facesynth learn``'s streaming sends it), every ``every``-th frame tracked:
        its time (the head's clock, ns), the pulses in force when it was taken, its face (over
        :data:`NAMES`). The commands are paced as the babbler paces them: no servo is asked to
        move faster than ``pace`` of its profile's ``max_speed``."""
        sim = self._sim
        start = sim.t_ns
        speeds = np.array([paced_speed(spec, pace) for spec in self.profile.servos])
        room = speeds * FRAME_NS / 1e9  # µs a frame, per servo
        channels = [spec.channel for spec in self.profile.servos]
        times, pulses, faces = [], [], []
        for index in range(round(seconds * 1e9 / FRAME_NS)):
            t_ns = index * FRAME_NS
            sim.step(start + t_ns)
            goal = self.pulses(trajectory.at(offset_s + t_ns / 1e9))
            in_force = sim.pulses()
            now = np.array([in_force[channel] for channel in channels])
            command = now + np.clip(goal - now, -room, room)
            self._command(command)
            if index % every:
                continue
            faces.append(self._track())
            times.append(sim.t_ns)
            pulses.append(command)
        return np.array(times, dtype=np.int64), np.array(pulses), np.array(faces)

    def _command(self, pulses: np.ndarray) -> None:
        """Every servo to ``pulses`` at once."""
        for spec, pulse in zip(self.profile.servos, pulses, strict=True):
            self._sim.command(spec.channel, float(pulse))


def babble(
    babbler: SimBabbler,
    poses: Iterable[tuple[str, np.ndarray]],
    on_sample: Callable[[str, np.ndarray, np.ndarray], None] | None = None,
) -> BabbleSet:
    """Each ``(kind, u)`` of ``poses`` looked at, in order, as a :class:`BabbleSet`;
    ``on_sample(kind, u, face)`` after each (a plan that adapts to what it has seen)."""
    commands, faces, kinds = [], [], []
    for kind, u in poses:
        face = babbler.look(np.asarray(u, dtype=np.float64))
        commands.append(babbler.pulses(np.asarray(u, dtype=np.float64)))
        faces.append(face)
        kinds.append(kind)
        if on_sample is not None:
            on_sample(kind, np.asarray(u, dtype=np.float64), face)
    return BabbleSet(
        servos=tuple(s.name for s in babbler.profile.servos),
        commands=np.array(commands).reshape(len(kinds), len(babbler.profile.servos)),
        inputs=NAMES,
        faces=np.array(faces, dtype=np.float64).reshape(len(kinds), len(NAMES)),
        kinds=tuple(kinds),
    )


def uniform_poses(
    servos: int, count: int, seed: int, neutral_every: int = 20
) -> list[tuple[str, np.ndarray]]:
    """``count`` uniform random poses in [-1, 1]^servos, a neutral every ``neutral_every``."""
    rng = np.random.default_rng(seed)
    return [
        ("neutral", np.zeros(servos))
        if index % neutral_every == 0
        else ("random", rng.uniform(-1.0, 1.0, servos))
        for index in range(count)
    ]


def held_out_error(profile: Profile, test: BabbleSet) -> tuple[float, float]:
    """``(raw, effective)``: the mean command error (fraction of range, over the fitted
    servos) of ``profile``'s inverse model on the non-neutral poses of ``test``, each face taken
    relative to ``test``'s own neutral (the median of its neutral poses)."""
    from facesynth.app.learn.fit import command_error

    learned = profile.learned
    if learned is None:
        raise ValueError(f"profile {profile.name} is not learned")
    columns = [test.inputs.index(name) for name in learned.inputs]
    faces = test.faces[:, columns]
    kinds = np.asarray(test.kinds)
    offset = np.nan_to_num(np.nanmedian(faces[kinds == "neutral"], axis=0))
    u = test.normalized(profile)[:, [test.servos.index(n) for n in learned.outputs]]
    keep = (kinds != "neutral") & np.all(np.isfinite(faces), axis=1)
    x = (faces[keep] - offset - unpack(learned.input_mean)) / unpack(learned.input_scale)
    predicted = predictor(learned.inverse)(x)
    wanted = u[keep]
    raw = command_error(profile, learned.outputs, predicted, wanted)
    low, high = command_range(learned)
    effective = command_error(
        profile, learned.outputs, np.clip(predicted, low, high), np.clip(wanted, low, high)
    )
    return float(raw.mean()), float(effective.mean())


#: The fewest poses a fit is asked for (it holds 20 % out and needs 10 different poses).
MIN_POSES = 60
#: The hardware profile of the 16-servo heads (the bundled simhead16* and every ``seed:N``).
HARDWARE = "head16_hardware"
#: The name of a profile learned in process (one column per head in ``bench robot``).
LEARNED_NAME = "learned"
#: The sweeps a profile learned in process starts with (``facesynth learn``'s default plan):
#: the fit finds the face's regions from them (:mod:`facesynth.app.learn.regional`).
SWEEP_STEPS = 3


def probe_lags(
    babbler: SimBabbler, step: float = PROBE_STEP, servos: Iterable[str] | None = None
) -> dict[str, float]:
    """Per servo (``servos``: these only), the head's response lag (s;
    :func:`~facesynth.app.learn.lag.servo_lags`) over four steps of ``step``, the others at
    neutral: out from neutral and back, each way, each followed frame by frame
    (:meth:`SimBabbler.follow`); servos the camera barely sees are left out."""
    count = len(babbler.profile.servos)
    chosen = None if servos is None else set(servos)
    transitions = []
    for index, spec in enumerate(babbler.profile.servos):
        if chosen is not None and spec.name not in chosen:
            continue
        rest = np.zeros(count)
        face = babbler.look(rest, 4)
        for sign in (1.0, 0.0, -1.0, 0.0):
            pose = rest.copy()
            pose[index] = sign * step
            times, faces = babbler.follow(pose)
            after = babbler.look(pose, 4)
            command = np.ones(len(times))
            transitions.append(Transition(spec.name, times, command, faces, face, after))
            face = after
    return servo_lags(transitions)


def babble_simhead(
    profile: Profile,
    poses: int,
    *,
    head: str = "simhead16",
    seed: int = 0,
    neutral_every: int = 20,
    frames: int = 2,
    sweep_steps: int = 0,
) -> BabbleSet:
    """``poses`` uniform random poses (normalized units, seeded) of the simulated head
    ``head`` (a name as :func:`~facesynth.app.simhead.load_head` takes it), each tracked for
    ``frames`` frames (the tracker follows its last face: more frames, less hysteresis).
    With ``sweep_steps``, the first poses are the sweeps ``facesynth learn`` starts with
    (:class:`~facesynth.app.learn.plan.Plan`: each servo alone, that many steps each way),
    from which the fit finds the face's regions, when they take at most half the poses
    (fewer poses: uniform ones only, as a fit refuses sweeps cut short)."""
    from facesynth.app.learn.plan import Plan, PlanOptions

    first: list[tuple[str, np.ndarray]] = []
    sweeps = Plan(len(profile.servos), PlanOptions(seed, max(sweep_steps, 1)))
    if sweep_steps and 2 * sweeps.sweep_poses <= poses:
        first = [
            (pose.kind, np.array(pose.u)) for pose in map(sweeps.pose, range(sweeps.sweep_poses))
        ]
    rest = uniform_poses(len(profile.servos), poses - len(first), seed, neutral_every)
    return babble(SimBabbler(profile, head, frames), first + rest)


def stream_simhead(
    profile: Profile,
    seconds: float,
    *,
    head: str = "simhead16",
    seed: int = 0,
    sweep_steps: int = SWEEP_STEPS,
) -> BabbleSet:
    """``facesynth learn --plan stream`` in virtual time: the sweeps of the plan (each pose
    looked at settled), the head's response lag probed (:func:`probe_lags`, as a session's
    sweeps measure it), then ``seconds`` of streaming along the seed's trajectory with every
    frame tracked (:meth:`SimBabbler.stream`) and a settled neutral every
    ``Streaming.neutral_every_s``, the frames paired at that lag
    (:meth:`~facesynth.app.learn.dataset.BabbleSet.with_stream`)."""
    from facesynth.app.learn.plan import Plan, PlanOptions

    babbler = SimBabbler(profile, head)
    sweeps = Plan(len(profile.servos), PlanOptions(seed, max(sweep_steps, 1)))
    poses = [(p.kind, np.array(p.u)) for p in map(sweeps.pose, range(sweeps.sweep_poses))]
    parts = [babble(babbler, poses)]
    lags = probe_lags(babbler)
    trajectory = Trajectory(len(profile.servos), seed)
    every = Streaming.neutral_every_s
    streamed = []
    for start in np.arange(0.0, seconds, every):
        streamed.append(babbler.stream(trajectory, min(every, seconds - start), 1, start))
        parts.append(babble(babbler, [("neutral", np.zeros(len(profile.servos)))]))
    settled = BabbleSet(
        parts[0].servos,
        np.vstack([part.commands for part in parts]),
        parts[0].inputs,
        np.vstack([part.faces for part in parts]),
        tuple(kind for part in parts for kind in part.kinds),
        lags,
    )
    times, pulses, faces = (np.concatenate(column) for column in zip(*streamed, strict=True))
    return settled.with_stream(times, pulses, faces, lags)


def hardware_for(head: HeadConfig) -> Profile:
    """The hardware profile whose servos are the head's actuators (same names on the same
    channels): head16_hardware for the 16-servo heads, head18_lids_hardware for a head with
    lids, …; ``ValueError`` when none has them."""
    wanted = {(a.name, a.channel) for a in head.actuators}
    names = [HARDWARE] + [
        name
        for name in available_profiles(hardware=True)
        if name.endswith("_hardware") and name != HARDWARE
    ]
    for name in names:
        profile = load_profile(name)
        if {(s.name, s.channel) for s in profile.servos} == wanted:
            return profile
    raise ValueError(
        f"head {head.name}: no hardware profile has its servos (names and channels) to babble it"
    )


def learn_simhead(head: str, poses: int, *, seed: int = 0) -> Profile:
    """A profile learned in process for the simulated head ``head`` (a name as
    :func:`~facesynth.app.simhead.load_head` takes it) from ``poses`` babbled poses, on
    :func:`hardware_for` the head, with the fit's default options, named
    :data:`LEARNED_NAME`; ``ValueError`` (one line) when it cannot be fitted (fewer than
    :data:`MIN_POSES` poses, no face, no hardware profile, scikit-learn missing)."""
    from facesynth.app.learn.fit import fit_learned_profile
    from facesynth.app.simhead import load_head

    if poses < MIN_POSES:
        raise ValueError(f"--learn-poses must be at least {MIN_POSES} (got {poses})")
    hardware = hardware_for(load_head(head))
    babbled = babble_simhead(hardware, poses, head=head, seed=seed, sweep_steps=SWEEP_STEPS)
    fitted = fit_learned_profile(babbled, hardware)
    return msgspec.structs.replace(fitted, name=LEARNED_NAME)
