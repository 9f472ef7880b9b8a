"""The loss budget of a learned profile on a simulated head
(facesynth/app/bench/likeness_budget.py): the oracle finds the commands of a face through a
head's true actuators, and the budget measures every stage end to end."""

from __future__ import annotations

import math

import numpy as np
import pytest

from facesynth.app.bench import likeness_budget
from facesynth.app.bench.likeness_budget import budget, oracle_commands, report
from facesynth.app.bench.robot import track_performer
from facesynth.app.data import sample_video
from facesynth.app.learn.fit import FitOptions, fit_learned_profile
from facesynth.app.learn.inprocess import SETTLE_NS, babble_simhead, hardware_for
from facesynth.app.simhead import SimHead, load_head
from facesynth.runtime.profiles import load_profile


class Actuators:
    """simhead16's true actuators without its camera: each effect's activation, settled."""

    def __init__(self) -> None:
        self.head = SimHead(load_head("simhead16"))
        self.servos = load_profile("head16_hardware").servos
        self.effects = sorted(self.head.activations() or self._settle(np.full(16, 0.9)))

    def _settle(self, u: np.ndarray) -> dict[str, float]:
        for spec, value in zip(self.servos, u, strict=True):
            travel = spec.max_us - spec.neutral_us if value >= 0 else spec.neutral_us - spec.min_us
            self.head.command(spec.channel, spec.neutral_us + value * travel)
        self.head.step(self.head.t_ns + SETTLE_NS)
        return self.head.activations()

    def face(self, u: np.ndarray) -> np.ndarray:
        active = self._settle(u)
        return np.array([active.get(name, 0.0) for name in self.effects])


def test_the_oracle_finds_a_reachable_face_through_the_true_actuators() -> None:
    head = Actuators()
    rng = np.random.default_rng(27)
    wanted = rng.uniform(-0.6, 0.6, 16)
    target = head.face(wanted)
    weights = np.ones(len(target))
    start = np.zeros(16)
    before = float(np.sum((head.face(start) - target) ** 2))
    u, face = oracle_commands(head, lambda f: f, target, weights, [start])
    after = float(np.sum((face - target) ** 2))
    assert after < 0.1 * before
    assert np.all(np.abs(u) <= 1.0)
    assert face == pytest.approx(head.face(u))


def test_the_oracle_keeps_the_better_start() -> None:
    head = Actuators()
    wanted = np.linspace(-0.5, 0.5, 16)
    target = head.face(wanted)
    weights = np.ones(len(target))
    _, face = oracle_commands(head, lambda f: f, target, weights, [np.zeros(16), wanted])
    assert np.sum((face - target) ** 2) <= 1e-12  # the exact command was among the starts


@pytest.mark.slow
@pytest.mark.timeout(900)
def test_the_budget_of_a_learned_profile_end_to_end() -> None:
    hardware = hardware_for(load_head("seed:2"))  # 60 poses: a partial fit is enough here
    babbled = babble_simhead(hardware, 60, head="seed:2")
    profile = fit_learned_profile(babbled, hardware, FitOptions(partial=True))
    performance = track_performer(str(sample_video()), frames=60)
    result = budget(performance, profile, "seed:2", oracle_every=10)
    names = [stage.name for stage in result.stages]
    assert names[:5] == ["target", "oracle", "sequence", "plan", "sent@0"]
    assert names[6] == "live@0" and names[7] == f"live@{result.best_lag}"
    assert 0 <= result.best_lag <= likeness_budget.LAGS
    by_name = {stage.name: stage for stage in result.stages}
    assert by_name["target"].mean_rho > 0.9  # the target follows her, within the reach
    assert by_name[names[7]].mean_rho >= by_name["live@0"].mean_rho
    assert all(math.isfinite(stage.mean_rho) for stage in result.stages)
    assert result.noise and all(v >= 0 for v in result.noise.values() if math.isfinite(v))
    text = report(result)
    assert "still-head noise / performer std" in text
    for name in result.features:
        assert name in text


@pytest.mark.parametrize(
    ("label", "argv", "message"),
    [
        ("a written profile", ["--profile", "head16"], "profile head16 is not learned"),
        ("an unknown head", ["--head", "nohead", "--profile", "head16"], "nohead"),
        ("no profile file", ["--profile", "./missing.learned"], "missing.learned"),
        ("oracle every 0", ["--profile", "head16", "--oracle-every", "0"], "at least 1 (got 0)"),
        ("rounds below 0", ["--profile", "head16", "--rounds", "-1"], "0 or more (got -1)"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(
    label: str, argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exited:
        likeness_budget.main(argv)
    assert exited.value.code == 2, label
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and message in err, err
    assert err.startswith("python -m facesynth.app.bench.likeness_budget: error: ")
