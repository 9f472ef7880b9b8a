"""T with its loop closed through the robot's face: the translator's part (the robot's features
in, standardized as the models see them; the commands that went out paired with them; limits,
speeds and a lost face), on a head computed in virtual time."""

from __future__ import annotations

import asyncio
import itertools
from pathlib import Path
from typing import Any

import msgspec
import numpy as np
import pytest
from msgspec.structs import replace
from test_translator_learned import INPUTS, learned_profile

from facesynth.runtime import codec, keys
from facesynth.runtime.profiles import Profile, load_profile
from facesynth.runtime.profiles.learned import PolyRidge, pack
from facesynth.runtime.testing import StageRun
from facesynth.schemas.messages import Features
from facesynth.services.translator.closed_loop import LoopOptions
from facesynth.services.translator.core import TranslationError, Translator
from facesynth.services.translator.loop_state import load_loop_state
from facesynth.services.translator.service import RobotFace, serve_translator

FRAME_NS = 33_333_333
#: The robot's face moves this share of what its self-model says (its skin stiffened).
WEAKER = 0.6


def closed_profile(**top: Any) -> Profile:
    """:func:`learned_profile` (servo i follows input i as ``u = t / 0.1``) with a self-model,
    its inverse: input i is ``0.1 u_i``, standardized ``x = u``."""
    profile = learned_profile(**top)
    assert profile.learned is not None
    forward = PolyRidge(
        degree=1, powers=pack(np.eye(3)), coef=pack(np.eye(3)), intercept=pack(np.zeros(3))
    )
    learned = msgspec.structs.replace(profile.learned, forward=forward)
    return msgspec.structs.replace(profile, learned=learned)


def performer(index: int, value: float) -> Features:
    raw = {name: value for name in INPUTS}
    return Features(
        seq=index,
        t_capture_ns=index * FRAME_NS,
        t_media_ns=index * FRAME_NS,
        face=True,
        neutral_ready=True,
        raw=raw,
        named={name: 1.0 for name in INPUTS},
    )


def robot_face(profile: Profile, positions: dict[str, float], index: int, face: bool) -> Features:
    """What the robot's camera sees: input i moves ``WEAKER`` of 0.1 u_i."""
    assert profile.learned is not None
    raw = {}
    for name, servo in zip(INPUTS, profile.learned.outputs, strict=True):
        spec = profile.servo(servo)
        offset = positions[servo] - spec.neutral_us
        u = offset / (
            spec.max_us - spec.neutral_us if offset >= 0 else spec.neutral_us - spec.min_us
        )
        raw[name] = WEAKER * 0.1 * u
    return Features(
        seq=index,
        t_capture_ns=index * FRAME_NS,
        t_media_ns=index * FRAME_NS,
        face=face,
        neutral_ready=True,
        raw=raw if face else {},
    )


def play(
    translator: Translator, frames: int, value: float, *, seen: bool = True, start: int = 0
) -> list[dict[str, float]]:
    out = []
    for index in range(start, start + frames):
        positions = translator.step(performer(index, value), now_ns=index * FRAME_NS)
        translator.observe(robot_face(translator.profile, positions, index, seen))
        out.append(positions)
    return out


def observed(profile: Profile, positions: dict[str, float]) -> float:
    return robot_face(profile, positions, 0, True).raw[INPUTS[0]]


def test_the_robots_face_reaches_the_target_the_open_loop_misses() -> None:
    profile = closed_profile()
    target = 0.05  # retargeted (a version 1 file): the performer's change, within the reach
    open_loop = play(Translator(profile), 60, 0.05)
    translator = Translator(profile)
    # (its servos all move at once: the loop cannot tell their slopes apart, so it is
    # corrected over the whole face, as the regions' own tests show in test_loop_regions)
    options = LoopOptions(damping=0.01, max_step=0.05, response_s=0.0, region_share=0.0)
    translator.close_loop(options)
    closed = play(translator, 90, 0.05)
    assert observed(profile, open_loop[-1]) == pytest.approx(WEAKER * target, rel=1e-6)
    assert observed(profile, closed[-1]) == pytest.approx(target, rel=0.05)


def test_the_loop_keeps_to_the_limits_and_speeds() -> None:
    profile = closed_profile()
    fast = [msgspec.structs.replace(s, max_speed=1500.0) for s in profile.servos]
    profile = msgspec.structs.replace(profile, servos=fast)
    translator = Translator(profile)
    translator.close_loop(LoopOptions(max_step=1.0, max_correction=2.0, damping=1e-6))
    frames = play(translator, 40, 0.1) + play(translator, 40, -0.05, start=40)
    for spec in profile.servos:
        track = np.array([f[spec.name] for f in frames])
        assert track.min() >= spec.min_us and track.max() <= spec.max_us
        assert np.abs(np.diff(track)).max() <= 1500.0 * FRAME_NS / 1e9 + 1e-6


def test_a_lost_robot_face_goes_back_to_the_open_loop() -> None:
    profile = closed_profile()
    open_loop = play(Translator(profile), 120, 0.05)
    translator = Translator(profile)
    translator.close_loop(LoopOptions(damping=0.01, max_step=0.05, response_s=0.0))
    closed = play(translator, 60, 0.05)
    assert closed[-1] != open_loop[59]
    lost = play(translator, 60, 0.05, seen=False, start=60)
    assert lost[-1] == open_loop[-1]  # back at the open loop's positions exactly
    steps = [abs(b[s] - a[s]) for a, b in itertools.pairwise(lost) for s in a]
    first = abs(lost[0][profile.servos[0].name] - closed[-1][profile.servos[0].name])
    assert max([first, *steps]) <= 0.05 * 500.0 + 1e-6  # max_step of a 500 µs half travel


def test_an_open_loop_translator_ignores_the_robots_face() -> None:
    profile = closed_profile()
    plain, observing = Translator(profile), Translator(profile)
    for index in range(20):
        expected = plain.step(performer(index, 0.05))
        positions = observing.step(performer(index, 0.05))
        observing.observe(robot_face(profile, positions, index, True))
        assert positions == expected


def test_only_a_learned_profile_with_a_self_model_closes_the_loop() -> None:
    with pytest.raises(TranslationError, match="is not learned: no closed loop"):
        Translator(load_profile("head16")).close_loop()
    with pytest.raises(TranslationError, match="needs a learned profile with a poly_ridge"):
        Translator(learned_profile()).close_loop()


# --- the shell: the robot's face on the bus ----------------------------------------------------


async def test_the_service_reads_the_robots_face_and_keeps_what_it_learned(
    tmp_path: Path,
) -> None:
    profile = closed_profile()
    assert profile.learned is not None
    path = tmp_path / "head.loop"
    robot_key = keys.stage_key("self", "features")
    translator = Translator(profile)
    face = RobotFace(key=robot_key, state_path=path)
    async with StageRun(
        lambda ctx: serve_translator(ctx, translator, robot=face), service="translator"
    ) as run:
        camera = run.network.bus()
        for index in range(10):
            await run.send("features", performer(index, 0.05))
            positions = run.messages("servo_commands")[-1].positions
            seen = robot_face(profile, positions, index, True)
            now = run.clock.time_ns()  # the robot camera's frame, captured now
            camera.publish(robot_key, codec.encode(replace(seen, t_capture_ns=now)))
            camera.publish(robot_key, b"\x93not a face")  # refused on arrival
            await run.advance(1 / 30)
        await camera.close()
    closed = translator.close_loop_once()
    assert closed.state.updates >= 9  # every face paired with the command then out
    state = load_loop_state(path, profile.learned)  # kept when the service stopped
    assert state is not None and state.updates == closed.state.updates
    assert np.array_equal(state.weights, closed.state.weights)


async def test_without_the_robots_face_the_service_is_open_loop() -> None:
    profile = closed_profile()
    translator = Translator(profile)
    async with StageRun(lambda ctx: serve_translator(ctx, translator), service="translator") as run:
        await run.send("features", performer(0, 0.05))
    assert translator._learned is not None and translator._learned.closed is None


async def test_the_service_keeps_the_state_every_so_often(tmp_path: Path) -> None:
    profile = closed_profile()
    path = tmp_path / "head.loop"
    face = RobotFace(key=keys.stage_key("self", "features"), state_path=path, save_every_s=5.0)
    async with StageRun(
        lambda ctx: serve_translator(ctx, Translator(profile), robot=face), service="translator"
    ) as run:
        await run.advance(4.0)
        assert not path.exists()
        await run.advance(1.5)
        for _ in range(200):  # written in a worker thread: real time, a moment
            if path.exists():
                break
            await asyncio.sleep(0.05)
        assert path.exists() and run.now < 6.0


class Tracked:
    """Faces tracked in this process (as ``--robot-camera``'s thread gives them)."""

    def __init__(self) -> None:
        self.waiting: list[Features] = []
        self.error: str | None = None
        self.closed = False

    def faces(self) -> list[Features]:
        out, self.waiting = self.waiting, []
        return out

    def close(self) -> None:
        self.closed = True


async def test_the_service_reads_faces_tracked_in_its_own_process(
    caplog: pytest.LogCaptureFixture,
) -> None:
    profile = closed_profile()
    translator = Translator(profile)
    tracked = Tracked()
    face = RobotFace(key=None, local=lambda: tracked)
    async with StageRun(
        lambda ctx: serve_translator(ctx, translator, robot=face), service="translator"
    ) as run:
        for index in range(6):
            await run.send("features", performer(index, 0.05))
            positions = run.messages("servo_commands")[-1].positions
            seen = robot_face(profile, positions, index, True)
            tracked.waiting.append(replace(seen, t_capture_ns=run.clock.time_ns()))
            await run.advance(1 / 30)
        tracked.error = "the robot's camera stopped delivering frames"
        await run.send("features", performer(6, 0.05))
        await run.send("features", performer(7, 0.05))
    assert translator.close_loop_once().state.updates >= 5
    assert tracked.closed
    said = [r.message for r in caplog.records if "the loop stays open" in r.message]
    assert said == ["the robot's camera stopped delivering frames: the loop stays open"]
