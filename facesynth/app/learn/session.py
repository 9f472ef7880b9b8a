"""A babbling session file: an MCAP recording with the ``…/babble`` samples, read and resumed.

A session is a facesynth recording (:mod:`facesynth.app.recording`) whose metadata says it is a
babbling session (``learn`` and the profile, its servos, the plan, its seed and the options
that shape it), holding the ``…/babble`` samples and, beside them, the features, servo commands
and states (and a frame now and then) of the run. :func:`read_session` reads one back;
:func:`babble_set` turns its samples into the :class:`~facesynth.app.learn.dataset.BabbleSet`
the fitting takes.

MCAP files are not appended to: a resumed run writes a new file beside the old one
(``OUT.resume``), copies every message of the old one into it first, records on, and replaces
the old file when it closes. A kill meanwhile leaves the old file as it was.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from facesynth.app.learn.dataset import KINDS, BabbleSet
from facesynth.app.learn.plan import PlanError
from facesynth.app.learn.plan_options import stored
from facesynth.app.learn.stream import MAX_GAP_S, STREAM_KIND
from facesynth.app.recording.layout import LAYOUT_VERSION, Layout
from facesynth.app.recording.reader import Recording, RecordingError
from facesynth.app.recording.writer import SessionWriter
from facesynth.runtime.profiles import Profile
from facesynth.schemas.messages import BabbleSample

log = logging.getLogger("facesynth.learn")

#: Metadata field marking a babbling session (its value: the session format's version).
LEARN_FIELD = "learn"
LEARN_VERSION = "1"
#: The babbling plans (``facesynth learn --plan``); a session that names none was babbled with
#: the first, the fixed plan. ``stream``: the fixed plan's sweeps, then streaming
#: (:mod:`facesynth.app.learn.stream`).
PLANS = ("fixed", "adaptive", "stream")


class SessionError(ValueError):
    """A file that is not a usable babbling session (or not for this profile)."""


@dataclass(frozen=True)
class Session:
    """What a babbling session file holds."""

    path: Path
    rig: str
    profile: str
    servos: tuple[str, ...]
    seed: int
    samples: list[BabbleSample]
    #: The babbling plan (one of :data:`PLANS`).
    plan: str = PLANS[0]
    #: The options that shaped the plan (:mod:`facesynth.app.learn.plan_options`); empty for
    #: a session written before they were kept.
    options: dict[str, int] = field(default_factory=dict)

    @property
    def next_pose(self) -> int:
        """Where a resumed run continues the plan: after the last pose taken (a stream's frames
        are no poses of the plan)."""
        return max((s.seq for s in self.samples if s.kind != STREAM_KIND), default=-1) + 1

    @property
    def streamed_s(self) -> float:
        """How long the session has streamed (s; its stream frames' span, gaps left out), where
        a resumed stream goes on along its trajectory."""
        times = np.sort([s.t_capture_ns for s in self.samples if s.kind == STREAM_KIND])
        steps = np.diff(times) / 1e9
        return float(steps[steps <= MAX_GAP_S].sum())


def metadata(
    rig: str,
    profile: Profile,
    seed: int,
    record: list[str],
    plan: str = PLANS[0],
    options: Mapping[str, str] | None = None,
) -> dict[str, str]:
    """The session metadata of a babbling run (a recording's, plus what ``learn`` needs:
    ``options``, the fields that keep the plan's options,
    :meth:`~facesynth.app.learn.plan_options.PlanChoice.metadata`)."""
    return {
        **(options or {}),
        "rig": rig,
        "keys": ",".join(record),
        "frame_every": "0",
        "started_ns": str(time.time_ns()),
        "layout": LAYOUT_VERSION,
        LEARN_FIELD: LEARN_VERSION,
        "learn_profile": profile.name,
        "learn_servos": ",".join(spec.name for spec in profile.servos),
        "learn_seed": str(seed),
        "learn_plan": plan,
    }


def read_session(path: str | Path) -> Session:
    """The babbling session in ``path``, or :class:`SessionError` saying why it is not one."""
    path = Path(path)
    try:
        with Recording(path) as recording:
            meta = recording.metadata
            if meta.get(LEARN_FIELD) != LEARN_VERSION:
                raise SessionError(
                    f"{path} is a facesynth recording but not a babbling session "
                    "(made by facesynth learn)"
                )
            try:
                seed = int(meta.get("learn_seed", ""))
            except ValueError:
                raise SessionError(f"{path}: the session names no plan seed") from None
            servos = tuple(name for name in meta.get("learn_servos", "").split(",") if name)
            profile = meta.get("learn_profile", "")
            plan = meta.get("learn_plan", PLANS[0])
            if plan not in PLANS:
                raise SessionError(f"{path}: the session's plan {plan!r} is not one of {PLANS}")
            if not servos or not profile:
                raise SessionError(f"{path}: the session names no profile or servos")
            try:
                options = stored(meta, plan, path)
            except PlanError as exc:
                raise SessionError(str(exc)) from None
            rig = recording.rig
            wanted = [k for k in recording.bus_keys() if k.endswith("/babble")]
            samples = [
                message
                for _, message, _ in recording.messages(wanted)
                if isinstance(message, BabbleSample)
            ]
    except RecordingError as exc:
        raise SessionError(f"not a babbling session: {exc}") from None
    return Session(path, rig, profile, servos, seed, samples, plan, options)


def check_profile(session: Session, profile: Profile) -> None:
    """Refuse to resume or fit a session with a profile whose servos are not the session's."""
    names = tuple(spec.name for spec in profile.servos)
    if names != session.servos:
        raise SessionError(
            f"{session.path} was babbled with profile {session.profile!r} "
            f"({len(session.servos)} servos: {', '.join(session.servos[:4])}…); "
            f"profile {profile.name!r} has other servos"
        )


def babble_set(
    samples: list[BabbleSample], profile: Profile, lags: Mapping[str, float] | None = None
) -> BabbleSet:
    """The samples as a :class:`BabbleSet`: commanded pulses per servo (the profile's order),
    raw features per input (sorted names; NaN where a sample lacks one), kinds; a stream's
    frames after the settled poses, each paired with the commands sent the head's response lag
    earlier (``lags``, per servo; :meth:`BabbleSet.with_stream`)."""
    servos = tuple(spec.name for spec in profile.servos)
    inputs = tuple(sorted({name for s in samples for name in s.features}))
    poses = [s for s in samples if s.kind != STREAM_KIND]
    commands, faces = _rows(poses, servos, inputs)
    kinds = tuple(s.kind if s.kind in KINDS else "random" for s in poses)
    settled = BabbleSet(servos, commands, inputs, faces, kinds, dict(lags or {}))
    stream = sorted((s for s in samples if s.kind == STREAM_KIND), key=lambda s: s.t_capture_ns)
    if not stream:
        return settled
    commands, faces = _rows(stream, servos, inputs)
    times = np.array([s.t_capture_ns for s in stream], dtype=np.int64)
    return settled.with_stream(times, commands, faces, settled.lags)


def _rows(
    samples: list[BabbleSample], servos: tuple[str, ...], inputs: tuple[str, ...]
) -> tuple[np.ndarray, np.ndarray]:
    commands = np.array(
        [[s.commanded.get(name, np.nan) for name in servos] for s in samples], dtype=np.float64
    ).reshape(len(samples), len(servos))
    faces = np.array(
        [[s.features.get(name, np.nan) for name in inputs] for s in samples], dtype=np.float64
    ).reshape(len(samples), len(inputs))
    if np.isnan(commands).any():
        raise SessionError("a babbling sample lacks a servo of the profile")
    return commands, faces


class SessionFile:
    """Where a run records: a new session, or a resumed one (see the module docstring)."""

    def __init__(self, path: str | Path, meta: dict[str, str], resume: Session | None) -> None:
        self.path = Path(path)
        self.resume = resume
        self.writing = self.path.with_name(self.path.name + ".resume") if resume else self.path
        if resume is not None and self.writing.exists():
            log.warning("replacing %s, left by an earlier resumed run", self.writing)
        self.writer = SessionWriter(self.writing, metadata=meta, overwrite=resume is not None)
        self.copied = 0
        if resume is not None:
            self._copy(resume.path)

    def _copy(self, old: Path) -> None:
        layout = Layout()
        sequence: dict[str, int] = {}
        try:
            with Recording(old) as recording:
                for item in recording.payloads(recording.bus_keys()):
                    index = sequence.get(item.key, 0)
                    sequence[item.key] = index + 1
                    for entry in layout.entries(item.key, item.payload, item.log_time, index):
                        self.writer.write(entry)
                    self.copied += 1
        except RecordingError as exc:
            self.writer.close()
            raise SessionError(f"cannot resume from {old}: {exc}") from None

    def close(self) -> None:
        """Complete the file (the writer must be closed); a resumed session replaces the old."""
        if self.writing != self.path:
            self.writing.replace(self.path)
