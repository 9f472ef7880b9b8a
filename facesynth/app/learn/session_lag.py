"""The head's response lag from a babbling session: each one-servo move, frame by frame.

A session (:mod:`facesynth.app.learn.session`) records, beside its settled poses, the
babbler's paced commands (``…/servo_commands``) and the face's features frame by frame
(``…/features``), both stamped on the wall clock (``t_capture_ns``: when the command was sent,
when the frame was taken). Between two settled poses that differ in one servo only (the sweeps,
and a neutral before or after one), the command moves that servo from the one pose to the
other and the face follows: a :class:`~facesynth.app.learn.lag.Transition`, its command's
progress read from the recorded commands (held between them), its face from the frames taken
after the first pose settled up to the second, its faces before and after the two poses'
settled features. :func:`session_lags` gives each servo's lag over them
(:func:`~facesynth.app.learn.lag.servo_lags`), which the fit reports.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from facesynth.app.learn.lag import Transition, servo_lags
from facesynth.app.recording.reader import Recording
from facesynth.schemas.messages import BabbleSample, Features, ServoCommands

__all__ = ["moves", "session_lags", "transitions"]

#: A servo whose command differs by more than this (µs) between two poses moved between them.
MOVED_US = 1.0


def session_lags(path: str | Path, samples: Sequence[BabbleSample]) -> dict[str, float]:
    """Per servo, the lag of its one-servo moves recorded in the session at ``path`` (its
    ``samples``, as :func:`~facesynth.app.learn.session.read_session` read them); empty when
    the session recorded no commands or features (``--record`` without them). Only the
    messages within a move are kept while reading."""
    spans = np.array([(a.t_capture_ns, b.t_capture_ns) for a, b, _ in moves(samples)])
    if not len(spans):
        return {}
    commands: list[ServoCommands] = []
    frames: list[Features] = []
    with Recording(path) as recording:
        wanted = [
            key for key in recording.bus_keys() if key.endswith(("/servo_commands", "/features"))
        ]
        for _, message, _ in recording.messages(wanted):
            index = np.searchsorted(spans[:, 0], message.t_capture_ns, "right") - 1
            if index < 0 or message.t_capture_ns >= spans[index, 1]:
                continue  # not within a move
            if isinstance(message, ServoCommands):
                commands.append(message)
            elif isinstance(message, Features) and message.face:
                frames.append(message)
    return servo_lags(transitions(samples, commands, frames))


def moves(samples: Sequence[BabbleSample]) -> list[tuple[BabbleSample, BabbleSample, str]]:
    """``(before, after, servo)``: consecutive settled poses (in time) that differ in one
    servo only."""
    poses = sorted((s for s in samples if s.settled), key=lambda s: s.t_capture_ns)
    found = []
    for before, after in itertools.pairwise(poses):
        moved = [
            name
            for name, value in after.commanded.items()
            if abs(value - before.commanded.get(name, value)) > MOVED_US
        ]
        if len(moved) == 1:
            found.append((before, after, moved[0]))
    return found


def transitions(
    samples: Sequence[BabbleSample],
    commands: Sequence[ServoCommands],
    frames: Sequence[Features],
) -> list[Transition]:
    """The one-servo moves between consecutive settled poses (see the module), with at least
    two frames each."""
    inputs = sorted({name for s in samples if s.settled for name in s.features})
    sent = sorted(commands, key=lambda c: c.t_capture_ns)
    sent_ns = np.array([c.t_capture_ns for c in sent], dtype=np.int64)
    frames = sorted(frames, key=lambda f: f.t_capture_ns)
    frame_ns = np.array([f.t_capture_ns for f in frames], dtype=np.int64)
    found = []
    for before, after, servo in moves(samples):
        start, end = before.t_capture_ns, after.t_capture_ns
        taken = frames[np.searchsorted(frame_ns, start, "right") : np.searchsorted(frame_ns, end)]
        if len(taken) < 2:
            continue
        times = np.array([f.t_capture_ns for f in taken], dtype=np.int64)
        last = np.searchsorted(sent_ns, times, "right") - 1  # the command in force at each frame
        old, new = before.commanded[servo], after.commanded[servo]
        pulses = np.array(  # before the move's first command: still the pose before
            [
                old if i < 0 or sent_ns[i] < start else sent[i].positions.get(servo, old)
                for i in last.tolist()
            ]
        )
        progress = np.clip((pulses - old) / (new - old), 0.0, 1.0)
        settled = np.array([before.features.get(n, np.nan) for n in inputs])
        faces = np.array([[f.raw.get(n, np.nan) for n in inputs] for f in taken])
        found.append(  # from the instant the pose before settled: its face, no command yet
            Transition(
                servo,
                np.concatenate([[0.0], (times - start) / 1e9]),
                np.concatenate([[0.0], progress]),
                np.vstack([settled, faces]),
                settled,
                np.array([after.features.get(n, np.nan) for n in inputs]),
            )
        )
    return found
