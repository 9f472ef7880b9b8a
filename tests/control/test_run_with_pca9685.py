"""``facesynth run … --driver pca9685``: the whole chain, in this process, drives the register
model of a PCA9685 (the real driver, registered on the model's bus as ``pca9685-model``;
a real ``/dev/i2c-*`` needs a kernel driver). The chip's outputs take, in order, the poses
the control interface reports sending (to the tick; one replaced by a newer before it was
written is skipped, none is made up); the run ends at neutral, asleep."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from fake_devices.pca9685 import FakeI2CAdapter, FakePCA9685
from patient_profiles import patient_profile
from pca9685_model_driver import model_driver
from test_run_with_boards import CHANNEL, CSV, FPS, PROFILE, expected_poses, recorded, sent_poses

from facesynth.app.cli import main
from facesynth.app.data import sample_video

TICK = 122 / 25e6 * 1e6  # (PRE_SCALE 121 + 1) / 25 MHz, in µs


def is_subsequence(seen: list[dict[int, int]], sent: list[dict[int, int]]) -> bool:
    """Whether every pose of ``seen`` is in ``sent``, in the same order."""
    rest = iter(sent)
    return all(any(pose == other for other in rest) for pose in seen)


def ticks(pose: dict[int, float]) -> dict[int, int]:
    """A pose in µs as the chip's ticks: rounded, limits rounded inward (the datasheet's unit)."""
    spec = {CHANNEL[s.name]: s for s in PROFILE.servos}
    return {
        ch: min(
            max(round(us / TICK), math.ceil(spec[ch].min_us / TICK)),
            math.floor(spec[ch].max_us / TICK),
        )
        for ch, us in pose.items()
    }


def run_on_the_model(tmp_path: Path, *source: str) -> tuple[FakePCA9685, Path, int]:
    """``facesynth run SOURCE --driver pca9685-model`` paced in real time, as a robot is driven
    (``--fast`` made the share of poses written a race between the replay and the I2C thread:
    50 of 113 on a fast CI machine); the chip, the session, the exit. paper16 lets commands
    age 5 s here (a loaded machine once stalled two of the video's past the 0.25 s default,
    which C rightly dropped, and the tests count every command)."""
    profile = patient_profile(tmp_path / "paper16-patient.toml")
    session = tmp_path / "s.mcap"
    chip = FakePCA9685()
    adapter = FakeI2CAdapter(tmp_path / "i2c-1", chip)
    with model_driver(adapter) as driver:
        code = main(
            ["run", *source, "--record", str(session), "--profile", str(profile),
             "--driver", driver, "--i2c-bus", str(adapter.path), "--pca9685-exit-hold", "0.05",
             "--listen", "tcp/127.0.0.1:0", "--log-level", "WARNING"]
        )  # fmt: skip
    return chip, session, code


def check_chip(chip: FakePCA9685, session: Path) -> None:
    """The chip took the poses C reports sending, in order, and ended at neutral, asleep."""
    seen = [{ch: round(us / TICK) for ch, us in pose.items()} for pose in chip.history]
    sent = [ticks(pose) for pose in sent_poses(session)]
    # The driver hands each pose to its I2C thread without waiting; one not yet written when a
    # newer one comes is replaced (only when the I2C thread falls a whole frame behind, at real
    # time). So the chip shows the poses sent, in their order, few if any skipped, none made up,
    # the last one last.
    # (seen[0] is the pose written at connect; seen[-1] the neutral written at close)
    assert is_subsequence(seen[1:-1], sent) and seen[-2] == sent[-1]
    assert len({tuple(p.values()) for p in seen}) > 30 and len(seen) > len(sent) // 2
    assert not chip.violations and chip.asleep  # neutral, then sleep
    neutral = {CHANNEL[name]: us for name, us in PROFILE.neutral_positions().items()}
    assert seen[-1] == ticks(neutral)


def test_run_drives_a_pca9685(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    chip, session, code = run_on_the_model(tmp_path, "--openface-csv", CSV, "--fps", str(FPS))
    assert code == 0
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    wanted = expected_poses()
    assert summary["commands"] == len(wanted)
    assert [pose for _, pose in recorded(session, "servo_commands")] == wanted
    check_chip(chip, session)


def test_run_from_the_performer_video_drives_a_pca9685(tmp_path: Path) -> None:
    """The tracker on the bundled video (72 frames), every safety rule of C in force."""
    chip, session, code = run_on_the_model(
        tmp_path, "--video", str(sample_video()), "--max-frames", "72"
    )
    assert code == 0
    commanded = [pose for move, pose in recorded(session, "servo_state") if move == "command"]
    assert len(commanded) == 72
    check_chip(chip, session)
