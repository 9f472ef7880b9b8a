"""The commands that follow a whole performance best through a self-model
(facesynth/app/plan/sequence.py): the objective's gradient, the search, its bounds,
smoothing and amplitude terms, the rehearsal on a robot the self-model gets wrong, bad input."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from facesynth.app.plan.sequence import (
    Likeness,
    correlation_shown,
    likeness_gradient,
    missed,
    rehearsed_commands,
    sequence_commands,
    sequence_faces,
)
from facesynth.runtime.profiles import load_profile
from facesynth.runtime.profiles.learned import PolyRidge, pack
from facesynth.services.translator.self_model_face import PolyFace

#: Degree-2 terms of two servos (scikit-learn's PolynomialFeatures without the bias).
POWERS = np.array([[1, 0], [0, 1], [2, 0], [1, 1], [0, 2]], dtype=np.float64)
LOW, HIGH = -np.ones(2), np.ones(2)


def model(coef: list[list[float]]) -> PolyFace:
    """A self-model over two servos with these coefficients (features × the five terms)."""
    array = np.asarray(coef, dtype=np.float64)
    ridge = PolyRidge(
        degree=2, powers=pack(POWERS), coef=pack(array), intercept=pack(np.zeros(len(array)))
    )
    return PolyFace(ridge)


#: Two servos, three features; the third is moved by both servos at once.
COUPLED = model([[1, 0, 0, 0, 0], [0, 1, 0, 0, 0], [1, 1, 0, 0, 0]])
#: The robot as it is: curved where the self-model is straight.
TRUE = model([[1, 0, 0.6, 0, 0], [0, 1, 0, 0, -0.5], [1, 1, 0, 0.8, 0]])


def performance(frames: int = 80) -> np.ndarray:
    """Targets for the three features: the third moves against the sum of the first two."""
    t = np.linspace(0, 4 * np.pi, frames)
    a, b = np.sin(t), np.sin(t + 1.0)
    return np.c_[a, b, -0.3 * (a + b) + 0.8 * np.cos(2 * t)]


def least_squares(targets: np.ndarray) -> np.ndarray:
    """Frame by frame, the commands nearest each target through COUPLED (linear), clipped."""
    a = np.array([[1, 0], [0, 1], [1, 1]], dtype=np.float64)
    out: np.ndarray = np.clip(np.linalg.lstsq(a, targets.T, rcond=None)[0].T, LOW, HIGH)
    return out


def faces(head: PolyFace, u: np.ndarray) -> np.ndarray:
    return np.array([head.at(np.append(v, 1.0))[0] for v in u])


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


def test_a_rehearsal_keeps_what_the_robot_showed_best() -> None:
    targets = performance()
    start = least_squares(targets)
    looks: list[np.ndarray] = []

    def look(commands: np.ndarray) -> np.ndarray:
        looks.append(commands)
        return faces(TRUE, commands)

    rehearsal = rehearsed_commands(COUPLED, look, targets, start, LOW, HIGH, rounds=3)
    assert len(rehearsal.commands) == len(rehearsal.shown) == 4  # the start and three rounds
    assert len(looks) == 4 and not rehearsal.stopped
    likeness = Likeness(targets, [0, 1, 2], 0.3, 0.5)
    on_robot = [likeness.value(faces(TRUE, u), u) for u in rehearsal.commands]
    assert rehearsal.shown == pytest.approx(on_robot)
    assert rehearsal.shown_rho == pytest.approx([likeness.mean_rho(faces(TRUE, u)) for u in looks])
    assert likeness.value(faces(TRUE, rehearsal.best), rehearsal.best) == max(on_robot)
    plain = sequence_commands(COUPLED, targets, start, LOW, HIGH).commands
    assert max(on_robot) > likeness.value(faces(TRUE, plain), plain) + 0.01


def test_a_face_the_robot_did_not_show_counts_as_the_self_models() -> None:
    targets = performance(20)
    start = least_squares(targets)

    def blind(commands: np.ndarray) -> np.ndarray:
        return np.full((len(commands), 3), np.nan)

    rehearsal = rehearsed_commands(COUPLED, blind, targets, start, LOW, HIGH, rounds=1)
    likeness = Likeness(targets, [0, 1, 2], 0.3, 0.5)
    assert rehearsal.shown[0] == pytest.approx(likeness.value(faces(COUPLED, start), start))
    assert np.isfinite(rehearsal.shown).all()


def test_a_profile_without_a_poly_ridge_self_model_is_refused() -> None:
    with pytest.raises(ValueError, match="no poly_ridge self-model"):
        sequence_faces(load_profile("head16"), lambda u: u, [None], [np.zeros(2)], {"x"})


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


def test_no_rehearsal_is_refused() -> None:
    targets = performance(10)
    with pytest.raises(ValueError, match="at least 1"):
        rehearsed_commands(
            COUPLED, lambda u: u, targets, least_squares(targets), LOW, HIGH, rounds=0
        )


@pytest.mark.parametrize("damping", [0.0, -0.5, 1.5, float("nan")])
def test_a_damping_outside_its_range_is_refused(damping: float) -> None:
    targets = performance(10)
    with pytest.raises(ValueError, match=r"damping must be within \(0, 1\]"):
        rehearsed_commands(
            COUPLED, lambda u: u, targets, least_squares(targets), LOW, HIGH, damping=damping
        )


def test_a_damped_round_moves_its_corrections_part_of_the_way() -> None:
    """Round 1 corrects for all the self-model missed at the plan; round 2 for the mean of
    that and what it missed at round 1's commands (damping 0.5); undamped, for the latter."""
    targets = performance()
    start = least_squares(targets)

    def missed_at(u: np.ndarray) -> np.ndarray:
        return faces(TRUE, u) - faces(COUPLED, u)

    def search(after: np.ndarray, offsets: np.ndarray) -> np.ndarray:
        found = sequence_commands(COUPLED, targets, after, LOW, HIGH, offsets=offsets)
        return found.commands

    first = search(start, missed_at(start))
    for damping, offsets in (
        (0.5, 0.5 * (missed_at(start) + missed_at(first))),
        (1.0, missed_at(first)),
    ):
        rehearsal = rehearsed_commands(
            COUPLED, lambda u: faces(TRUE, u), targets, start, LOW, HIGH, rounds=2, damping=damping
        )
        np.testing.assert_allclose(rehearsal.commands[1], first)
        np.testing.assert_allclose(rehearsal.commands[2], search(first, offsets))
    assert not np.allclose(missed_at(start), missed_at(first))  # so the two differ


def test_a_robot_looked_at_every_third_frame_still_corrects_the_plan() -> None:
    targets = performance()
    start = least_squares(targets)
    every_third = np.arange(len(targets)) % 3 == 0

    def glance(commands: np.ndarray) -> np.ndarray:
        seen = faces(TRUE, commands)
        seen[~every_third] = np.nan
        return seen

    rehearsal = rehearsed_commands(COUPLED, glance, targets, start, LOW, HIGH, rounds=3)
    likeness = Likeness(targets, [0, 1, 2], 0.3, 0.5)
    shown = faces(TRUE, start)[every_third]
    on_those = Likeness(targets[every_third], [0, 1, 2], 0.3, 0.5).mean_rho(shown)
    assert rehearsal.shown_rho[0] == pytest.approx(on_those)  # over the frames it showed
    best = likeness.value(faces(TRUE, rehearsal.best), rehearsal.best)
    plain = sequence_commands(COUPLED, targets, start, LOW, HIGH).commands
    assert best > likeness.value(faces(TRUE, plain), plain) + 0.01


def test_the_correlation_shown_counts_the_frames_and_features_shown() -> None:
    t = np.linspace(0, 6, 12)
    targets = np.c_[np.sin(t), np.cos(t), np.ones(12)]
    seen = np.c_[2 * np.sin(t) + 1, -np.cos(t), np.arange(12.0)]
    seen[5] = np.nan  # not shown: left out
    assert correlation_shown(targets[:, :2], seen[:, :2]) == pytest.approx(0.0)  # 1 and -1
    assert correlation_shown(targets, seen) == pytest.approx(0.0)  # a still target: left out
    assert np.isnan(correlation_shown(targets[:3], np.full((3, 3), np.nan)))
    assert np.isnan(correlation_shown(targets[:, 2:], seen[:, 2:]))  # nothing moves in both


def test_what_the_self_model_missed_is_interpolated_between_the_frames_shown() -> None:
    errors = np.array([[np.nan, np.nan], [1.0, np.nan], [np.nan, np.nan], [3.0, np.nan]])
    filled = missed(errors)
    assert filled[:, 0].tolist() == [1.0, 1.0, 2.0, 3.0]  # the nearest before the first
    assert filled[:, 1].tolist() == [0.0] * 4  # never shown: nothing added


def test_a_rehearsal_stopped_keeps_the_rounds_shown() -> None:
    targets = performance(20)
    start = least_squares(targets)
    answers = iter([faces(TRUE, start), None])

    def stopping(commands: np.ndarray) -> np.ndarray | None:
        return next(answers)

    rehearsal = rehearsed_commands(COUPLED, stopping, targets, start, LOW, HIGH, rounds=3)
    assert rehearsal.stopped and len(rehearsal.commands) == len(rehearsal.shown) == 1
    assert np.array_equal(rehearsal.best, start)
    none = rehearsed_commands(COUPLED, lambda u: None, targets, start, LOW, HIGH, rounds=3)
    assert none.stopped and none.commands == []
