"""The whole performance's commands rehearsed on a robot the self-model gets wrong
(facesynth/app/plan/sequence_rehearsed.py): the round shown best is kept, faces not shown,
damping, a robot looked at every third frame, a stopped rehearsal, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from two_servo_models import COUPLED, HIGH, LOW, TRUE, faces, least_squares, performance

from facesynth.app.plan.sequence import Likeness, sequence_commands
from facesynth.app.plan.sequence_rehearsed import (
    correlation_shown,
    missed,
    rehearsed_commands,
    sequence_faces,
)
from facesynth.runtime.profiles import load_profile


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
