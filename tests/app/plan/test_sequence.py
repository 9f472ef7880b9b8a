"""The commands that follow a whole performance best through a self-model
(facesynth/app/plan/sequence.py): the objective's gradient, the search, its bounds,
smoothing and amplitude terms, bad input."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
from two_servo_models import COUPLED, HIGH, LOW, faces, least_squares, model, performance

from facesynth.app.plan.sequence import Likeness, likeness_gradient, sequence_commands


def test_the_gradient_is_the_objectives_slope() -> None:
    rng = np.random.default_rng(27)
    head = model(rng.normal(size=(3, 5)).tolist())
    targets = performance(12)
    likeness = Likeness(targets, [0, 1, 2], amplitude=0.3, smooth=0.5, before=np.zeros(2))
    u = rng.uniform(-0.8, 0.8, (12, 2))
    offsets = rng.normal(scale=0.1, size=(12, 3))
    _, gradient = likeness_gradient(head, likeness, u, offsets)
    step = 1e-6
    for k, s in [(0, 0), (5, 1), (11, 0), (7, 1)]:
        up, down = u.copy(), u.copy()
        up[k, s] += step
        down[k, s] -= step
        slope = (
            likeness_gradient(head, likeness, up, offsets)[0]
            - likeness_gradient(head, likeness, down, offsets)[0]
        ) / (2 * step)
        assert gradient[k, s] == pytest.approx(slope, rel=1e-4, abs=1e-7)


def test_the_search_raises_the_objective_within_the_bounds() -> None:
    targets = performance()
    start = least_squares(targets)
    low, high = np.array([-0.5, -1.0]), np.array([1.0, 0.4])
    found = sequence_commands(COUPLED, targets, start, low, high)
    assert found.value > found.start_value + 0.01
    assert -1.0 <= found.start_rho < found.rho <= 1.0
    assert np.all(found.commands >= low) and np.all(found.commands <= high)
    assert found.iterations >= 1


def test_correlation_alone_follows_better_than_least_squares_frame_by_frame() -> None:
    targets = performance()
    start = least_squares(targets)

    def mean_rho(u: np.ndarray) -> float:
        f = faces(COUPLED, u)
        return float(np.mean([np.corrcoef(f[:, j], targets[:, j])[0, 1] for j in range(3)]))

    found = sequence_commands(COUPLED, targets, start, LOW, HIGH, amplitude=0.0, smooth=0.0)
    assert mean_rho(found.commands) > mean_rho(start) + 0.05  # 0.58 → 0.65: feature 0 let go


def test_the_jump_term_smooths_the_commands() -> None:
    targets = performance()
    start = least_squares(targets)
    rough = sequence_commands(COUPLED, targets, start, LOW, HIGH, smooth=0.0).commands
    smooth = sequence_commands(COUPLED, targets, start, LOW, HIGH, smooth=5.0).commands
    jumps = [float(np.mean(np.diff(u, axis=0) ** 2)) for u in (rough, smooth)]
    assert jumps[1] < 0.7 * jumps[0]


def test_the_jump_from_the_commands_before_counts() -> None:
    targets = performance()
    start = least_squares(targets)
    free = sequence_commands(COUPLED, targets, start, LOW, HIGH).commands
    held = sequence_commands(COUPLED, targets, start, LOW, HIGH, before=np.zeros(2)).commands
    assert np.abs(held[0]).max() < 0.8 * np.abs(free[0]).max()


def test_the_amplitude_term_keeps_the_targets_spread() -> None:
    targets = performance()
    start = least_squares(targets)
    spreads = []
    for amplitude in (0.0, 1.0):
        found = sequence_commands(
            COUPLED, targets, start, LOW, HIGH, amplitude=amplitude, smooth=0.0
        )
        ratio = faces(COUPLED, found.commands).std(axis=0) / targets.std(axis=0)
        spreads.append(np.abs(np.log(ratio)))
    assert spreads[1].max() < 0.1  # each feature within 10 % of the spread asked
    assert spreads[0].max() > 1.0  # correlation alone lets one collapse (here: feature 0)


def _bad(**change: object) -> Callable[[], object]:
    targets = performance(10)
    arguments: dict[str, object] = {
        "model": COUPLED,
        "targets": targets,
        "start": least_squares(targets),
        "low": LOW,
        "high": HIGH,
    }
    arguments.update(change)
    return lambda: sequence_commands(**arguments)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("label", "call", "message"),
    [
        ("two frames", _bad(targets=performance(2), start=np.zeros((2, 2))), "at least 3"),
        ("starts of another size", _bad(start=np.zeros((10, 3))), "starts are (10, 3)"),
        ("a feature too many", _bad(targets=np.ones((10, 4))), "4 features, the model 3"),
        ("NaN in a target", _bad(targets=np.where(np.eye(10, 3) > 0, np.nan, 1.0)), "finite"),
        ("a still feature", _bad(targets=np.c_[performance(10)[:, :2], np.ones(10)]), "[2]"),
        ("bounds upside down", _bad(low=np.ones(2), high=-np.ones(2)), "low <= high"),
        ("a column out of range", _bad(features=[0, 3]), "below 3"),
        ("no column", _bad(features=[]), "column indices"),
        ("a negative weight", _bad(smooth=-1.0), ">= 0"),
        ("offsets of another size", _bad(offsets=np.zeros((10, 2))), "offsets must be"),
        ("infinite offsets", _bad(offsets=np.full((10, 3), np.inf)), "offsets must be"),
        ("a command before of another size", _bad(before=np.zeros(3)), "2 finite commands"),
        ("a NaN command before", _bad(before=np.array([0.0, np.nan])), "2 finite commands"),
    ],
)
def test_bad_input_is_a_clear_error(label: str, call: Callable[[], object], message: str) -> None:
    with pytest.raises(ValueError) as raised:
        call()
    assert message in str(raised.value), label
