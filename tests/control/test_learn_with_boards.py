"""``facesynth learn`` works unchanged with the other serial drivers (issue 17): the same
command with ``--driver arduino`` (our firmware on the emulated Uno, PCA9685 pulses measured on
the emulated I2C bus) and ``--driver ssc32`` (an SSC-32U on a pty), the robot's camera being the
simulated head's MJPEG URL. The head is not wired to these boards, so its face stays still: every
pose settles, is recorded, and the board's pulses follow the babbling within the profile's
limits, then go back to neutral."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from facesynth_processes import Processes, run_facesynth
from uno_rig import near

from facesynth.app.learn.session import read_session
from facesynth.runtime.profiles import load_profile

pytestmark = pytest.mark.slow

POSES = 6


def _camera(processes: Processes, tmp_path: Path) -> str:
    link = str(tmp_path / "simhead-tty")
    return processes.start_simhead(link)


def _learn(driver: str, port: Path, camera: str, session: Path) -> dict[str, Any]:
    done = run_facesynth(
        "learn", "--profile", "paper16", "--driver", driver, "--port", str(port),
        "--camera", camera, "--out", str(session), "--poses", str(POSES), "--no-fit",
        "--log-level", "WARNING", timeout=180,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    summary: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    assert summary["poses"] == summary["taken"] == POSES, summary
    samples = read_session(session).samples
    assert [s.seq for s in samples] == list(range(POSES))
    assert all(s.features and s.settled for s in samples)
    return summary


def test_learn_with_the_firmware_on_the_emulated_uno(
    uno: Any, processes: Processes, tmp_path: Path
) -> None:
    _learn("arduino", uno.port, _camera(processes, tmp_path), tmp_path / "uno.mcap")
    profile = load_profile("paper16")
    channels = {spec.channel: spec for spec in profile.servos}
    seen = {pulse.channel for pulse in uno.pulses() if pulse.channel in channels}
    assert seen == set(channels)  # every servo's pulses are on (neutral first)
    first = profile.servos[0]  # the plan's first sweep: its servo alone, out and back
    swept = [p.width_us for p in uno.pulses() if p.channel == first.channel]
    assert max(abs(w - first.neutral_us) for w in swept) > 100
    for pulse in uno.pulses():  # never beyond a servo's limits (to the PCA9685's step)
        spec = channels.get(pulse.channel)
        if spec is not None:
            assert spec.min_us - 5 <= pulse.width_us <= spec.max_us + 5, pulse
    widths = uno.widths()
    assert all(near(widths[ch], spec.neutral_us) for ch, spec in channels.items())


def test_learn_with_an_ssc32(ssc32: Any, processes: Processes, tmp_path: Path) -> None:
    _learn("ssc32", ssc32.link, _camera(processes, tmp_path), tmp_path / "ssc32.mcap")
    profile = load_profile("paper16")
    moved = {channel for move in ssc32.moves for channel in move.widths}
    assert {spec.channel for spec in profile.servos} <= moved  # every servo's pulses are on
    first = profile.servos[0]  # the plan's first sweep: its servo alone, out and back
    swept = [m.widths[first.channel] for m in ssc32.moves if first.channel in m.widths]
    assert max(abs(w - first.neutral_us) for w in swept) > 100
    for spec in profile.servos:
        targets = [m.widths[spec.channel] for m in ssc32.moves if spec.channel in m.widths]
        assert all(spec.min_us <= t <= spec.max_us for t in targets), spec.name
        assert abs(ssc32.widths[spec.channel] - spec.neutral_us) <= 1, spec.name
