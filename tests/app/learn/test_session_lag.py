"""The head's response lag read from a babbling session (facesynth/app/learn/session_lag.py):
the one-servo moves between settled poses, their paced commands and the face's frames as the
session records them; a known lag is recovered, moves of two servos are not used, and a session
that recorded no commands or frames gives none."""

from __future__ import annotations

from pathlib import Path

import msgspec
import numpy as np
import pytest

from facesynth.app.learn.lag import transition_lag
from facesynth.app.learn.session import metadata, read_session
from facesynth.app.learn.session_lag import session_lags, transitions
from facesynth.app.recording.layout import Layout
from facesynth.app.recording.writer import SessionWriter
from facesynth.runtime import codec
from facesynth.runtime.profiles import load_profile
from facesynth.schemas.messages import BabbleSample, Features, ServoCommands

S = 1_000_000_000
FRAME_NS = S // 30
#: How late the face follows its command (s), and how long a move's command is paced over.
LAG_S, RAMP_S = 0.07, 0.2
#: Two servos' poses, one a second: each move but the last changes one servo.
POSES = [
    ("neutral", {"jaw": 1500.0, "right_eyebrow": 1500.0}),
    ("sweep", {"jaw": 1700.0, "right_eyebrow": 1500.0}),
    ("sweep", {"jaw": 1700.0, "right_eyebrow": 1300.0}),
    ("random", {"jaw": 1400.0, "right_eyebrow": 1600.0}),
]
#: The face each servo moves (per µs from neutral).
EFFECT = {"jaw": {"jaw_open": 0.002, "lips_part": 0.001}, "right_eyebrow": {"brow_raise": -0.001}}


def face(pulses: dict[str, float]) -> dict[str, float]:
    out = {"jaw_open": 0.0, "lips_part": 0.0, "brow_raise": 0.0}
    for servo, effects in EFFECT.items():
        for name, amount in effects.items():
            out[name] += amount * (pulses[servo] - 1500.0)
    return out


def paced(old: dict[str, float], new: dict[str, float], seconds: float) -> dict[str, float]:
    """The command ``seconds`` into a move from ``old`` to ``new`` paced over RAMP_S."""
    share = min(max(seconds / RAMP_S, 0.0), 1.0)
    return {name: old[name] + share * (new[name] - old[name]) for name in new}


def recorded() -> tuple[list[BabbleSample], list[ServoCommands], list[Features]]:
    """The poses settled at 1, 2, 3, 4 s; each move's command paced over RAMP_S from the
    instant the pose before settled, sent every frame; the face LAG_S behind it."""
    samples, commands, frames = [], [], []
    for index, (kind, pulses) in enumerate(POSES):
        settled = (index + 1) * S
        samples.append(
            BabbleSample(
                seq=index,
                t_capture_ns=settled,
                t_media_ns=settled,
                profile="head16_hardware",
                kind=kind,
                commanded=pulses,
                features=face(pulses),
            )
        )
        if index == 0:
            continue
        old = POSES[index - 1][1]
        for k in range(1, 30):
            t_ns = index * S + k * FRAME_NS

            since = (t_ns - index * S) / S
            commands.append(
                ServoCommands(
                    seq=len(commands),
                    t_capture_ns=t_ns,
                    t_media_ns=t_ns,
                    face=True,
                    profile="head16_hardware",
                    positions=paced(old, pulses, since),
                )
            )
            raw = face(paced(old, pulses, since - LAG_S))
            frames.append(
                Features(seq=len(frames), t_capture_ns=t_ns, t_media_ns=t_ns, face=True, raw=raw)
            )
    return samples, commands, frames


def test_a_known_lag_is_recovered_from_the_one_servo_moves() -> None:
    found = transitions(*recorded())
    assert [t.servo for t in found] == ["jaw", "right_eyebrow"]  # the last moved both
    for transition in found:
        assert transition.command[0] == 0.0  # the instant the pose before settled
        assert transition.command[1] == pytest.approx(1 / 30 / RAMP_S)
        assert transition.command[-1] == 1.0
        assert transition_lag(transition) == pytest.approx(LAG_S, abs=2e-3)


def test_unsettled_poses_and_moves_without_frames_are_left_out() -> None:
    samples, commands, frames = recorded()
    unsettled = msgspec.structs.replace(samples[2], settled=False)  # its face is no "after"
    kept = transitions([*samples[:2], unsettled, samples[3]], commands, frames)
    assert [t.servo for t in kept] == ["jaw"]
    assert transitions(samples, commands, frames[:1]) == []


def test_a_recorded_session_gives_each_servo_its_lag(tmp_path: Path) -> None:
    samples, commands, frames = recorded()
    path = tmp_path / "head.mcap"
    profile = load_profile("head16_hardware")
    keys = ["babble", "servo_commands", "features"]
    writer = SessionWriter(path, metadata=metadata("self", profile, 0, keys))
    layout = Layout()
    messages = [
        *(("babble", m) for m in samples),
        *(("servo_commands", m) for m in commands),
        *(("features", m) for m in frames),
    ]
    for index, (stage, message) in enumerate(messages):
        key = f"facesynth/self/{stage}"
        for entry in layout.entries(key, codec.encode(message), message.t_capture_ns, index):
            writer.write(entry)
    writer.close()
    session = read_session(path)
    lags = session_lags(path, session.samples)
    assert sorted(lags) == ["jaw", "right_eyebrow"]
    assert np.allclose(list(lags.values()), LAG_S, atol=2e-3)


def test_a_session_of_settled_poses_only_gives_no_lag(tmp_path: Path) -> None:
    samples, _, _ = recorded()
    path = tmp_path / "poses.mcap"
    writer = SessionWriter(path, metadata=metadata("self", load_profile("head16_hardware"), 0, []))
    layout = Layout()
    for index, sample in enumerate(samples):
        key = "facesynth/self/babble"
        for entry in layout.entries(key, codec.encode(sample), sample.t_capture_ns, index):
            writer.write(entry)
    writer.close()
    assert session_lags(path, read_session(path).samples) == {}
