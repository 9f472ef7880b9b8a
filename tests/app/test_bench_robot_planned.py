"""``bench robot --planned``: a learned profile's plan of the whole performance played through
C onto a simulated head in virtual time, beside T frame by frame (and ``--closed-loop``'s
variant beside both). A learned profile is fitted here from the head's own babbling."""

from __future__ import annotations

from pathlib import Path

import msgspec
import numpy as np
import pytest
from simhead16_laugh import HEAD, laughing, learned_simhead16

from facesynth.app.bench.robot import Performance
from facesynth.app.bench.robot_closed import CLOSED_SUFFIX, closed_runner
from facesynth.app.bench.robot_planned import PLANNED_SUFFIX, PlannedRobotLoop, run_planned
from facesynth.app.bench.robot_variants import bench_variants
from facesynth.app.cli import main
from facesynth.app.plan.performance import plan_performance
from facesynth.app.simhead import SimHead, load_head
from facesynth.runtime.profiles import Profile, save_learned_profile

pytestmark = [pytest.mark.slow, pytest.mark.timeout(900)]


@pytest.fixture(scope="module")
def learned() -> Profile:
    return msgspec.structs.replace(learned_simhead16(), name="robot")


@pytest.fixture(scope="module")
def performance() -> Performance:
    return laughing()  # she laughs


class PulseHead(SimHead):
    """simhead16 that keeps every pulse it is sent."""

    def __init__(self) -> None:
        super().__init__(load_head(HEAD))
        self.sent: list[tuple[int, float]] = []

    def command(self, channel: int, pulse_us: float) -> None:
        self.sent.append((channel, pulse_us))
        super().command(channel, pulse_us)


def test_every_planned_command_goes_through_c_within_the_limits(
    learned: Profile, performance: Performance
) -> None:
    plan = plan_performance(learned, performance.features)
    head = PulseHead()
    loop = PlannedRobotLoop(learned, head, plan.commands(), fps=performance.fps)
    for frame in performance.features:
        loop.step(frame)
    assert loop.played == len(performance.features)
    limits = {spec.channel: (spec.min_us, spec.max_us) for spec in learned.servos}
    assert head.sent and all(limits[c][0] <= p <= limits[c][1] for c, p in head.sent)
    # past the plan C gets nothing more: it catches up with the last command's targets
    last_ns = performance.features[-1].t_media_ns
    for k in range(1, 6):
        later = msgspec.structs.replace(
            performance.features[-1], t_media_ns=last_ns + k * 20_000_000
        )
        loop.step(later)
    assert loop.played == len(performance.features)
    by_channel = dict(head.sent)
    last = plan.positions[-1]
    for spec in learned.servos:
        assert by_channel[spec.channel] == pytest.approx(last[spec.name], abs=1.0)


def test_a_plan_runs_beside_the_open_and_the_closed_loop(
    learned: Profile, performance: Performance
) -> None:
    result = bench_variants(
        performance,
        [HEAD],
        ["head16"],
        lambda name: SimHead(load_head(name)),
        {PLANNED_SUFFIX: run_planned, CLOSED_SUFFIX: closed_runner()},
        learn=lambda head: [learned],
    )
    (head,) = result.heads
    runs = {run.profile: run for run in head.profiles}
    assert list(runs) == ["head16", "robot", "robot" + PLANNED_SUFFIX, "robot" + CLOSED_SUFFIX]
    rho = {name: run.summary.mean_rho for name, run in runs.items()}
    assert all(np.isfinite(list(rho.values())))
    # her laugh planned whole is followed better than frame by frame (0.48 against 0.40 here)
    assert rho["robot" + PLANNED_SUFFIX] > rho["robot"] + 0.03


@pytest.mark.parametrize("option", ["--planned", "--closed-loop"])
def test_a_learned_profile_without_a_self_model_is_refused_before_tracking(
    option: str, learned: Profile, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert learned.learned is not None
    blind = msgspec.structs.replace(
        learned, learned=msgspec.structs.replace(learned.learned, forward=None, plan_steps=0)
    )
    path = tmp_path / "blind.learned"
    save_learned_profile(blind, path)
    assert main(["bench", "robot", option, "--profile", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{option}: profile {path} has no poly_ridge self-model" in err
    assert "tracking the performer" not in err
