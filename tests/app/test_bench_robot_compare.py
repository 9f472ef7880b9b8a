"""facesynth.app.bench.robot_compare: ρ, amplitude ratio, moved and reachable features."""

from __future__ import annotations

import math

import numpy as np
import pytest

from facesynth.app.bench.robot_compare import (
    MOVED_SPAN,
    FeatureRow,
    FeatureStream,
    best_lag,
    compare,
    lead,
    mark_reach,
    moved_threshold,
    reach_ratio,
    span,
    summarize,
)

N = 200
T = np.linspace(0.0, 4 * np.pi, N)


def stream(**columns: np.ndarray) -> FeatureStream:
    names = tuple(columns)
    return FeatureStream(names, np.stack([columns[n] for n in names], axis=1))


def by_name(rows: list[FeatureRow]) -> dict[str, FeatureRow]:
    return {row.name: row for row in rows}


def test_thresholds_per_unit() -> None:
    assert moved_threshold("jaw_open") == MOVED_SPAN["inter-ocular distance"] == 0.02
    assert moved_threshold("head_yaw") == 3.0
    assert moved_threshold("gaze_left_x") == 0.04
    assert moved_threshold("eye_open_left") == 0.05
    assert moved_threshold("mouthSmileLeft") == 0.1
    with pytest.raises(ValueError, match="unknown feature 'smirk'"):
        moved_threshold("smirk")


def test_span_is_robust_to_outliers_and_ignores_nan() -> None:
    values = np.linspace(0.0, 1.0, 101)
    assert span(values) == pytest.approx(0.9)
    spiked = values.copy()
    spiked[50] = 1e6
    spiked[10] = np.nan
    assert span(spiked) == pytest.approx(0.9, abs=0.02)
    assert math.isnan(span(np.full(5, np.nan)))


def test_a_faithful_robot_a_half_robot_an_inverted_one_and_a_lagging_one() -> None:
    wave = 0.1 * np.sin(T)
    performer = stream(jaw_open=wave, lips_part=wave, lip_pucker=wave, cheek_raise_left=wave)
    robot = stream(
        jaw_open=wave,
        lips_part=0.5 * wave + 0.01,  # an offset does not matter, the amplitude does
        lip_pucker=-wave,
        cheek_raise_left=0.1 * np.sin(T - np.pi / 2),  # a quarter period late: uncorrelated
    )
    rows = by_name(compare(performer, robot))
    assert rows["jaw_open"].rho == pytest.approx(1.0)
    assert rows["jaw_open"].ratio == pytest.approx(1.0)
    assert rows["jaw_open"].in_band
    assert rows["lips_part"].rho == pytest.approx(1.0)
    assert rows["lips_part"].ratio == pytest.approx(0.5)
    assert not rows["lips_part"].in_band
    assert rows["lip_pucker"].rho == pytest.approx(-1.0)
    assert abs(rows["cheek_raise_left"].rho) < 0.05
    assert all(row.moved and row.frames == N for row in rows.values())
    assert rows["jaw_open"].unit == "inter-ocular distance"


def test_still_features_are_not_moved_and_a_still_robot_correlates_zero() -> None:
    performer = stream(jaw_open=0.005 * np.sin(T), mouthSmileLeft=0.4 * np.sin(T))
    robot = stream(jaw_open=0.005 * np.sin(T), mouthSmileLeft=np.zeros(N))
    rows = by_name(compare(performer, robot))
    assert not rows["jaw_open"].moved  # 0.01 IOD span < 0.02
    smile = rows["mouthSmileLeft"]
    assert smile.moved and smile.rho == 0.0 and smile.ratio == 0.0 and smile.robot_span == 0.0


def test_frames_without_a_value_are_left_out_on_either_side() -> None:
    wave = 0.1 * np.sin(T)
    theirs, ours = wave.copy(), wave.copy()
    theirs[:50] = np.nan  # e.g. F's neutral not known yet
    ours[100:120] = np.nan  # the robot's face lost
    ours[:50] = 99.0  # never compared: the performer has no value there
    row = compare(stream(gaze_left_x=theirs), stream(gaze_left_x=ours))[0]
    assert row.frames == N - 50 - 20
    assert row.rho == pytest.approx(1.0) and row.ratio == pytest.approx(1.0)


def test_a_feature_the_robot_never_shows() -> None:
    performer = stream(head_yaw=10 * np.sin(T), jaw_open=0.1 * np.sin(T))
    robot = stream(jaw_open=0.1 * np.sin(T))  # no head_yaw column at all
    rows = by_name(compare(performer, robot))
    assert rows["head_yaw"].moved and rows["head_yaw"].frames == 0
    assert rows["head_yaw"].rho == 0.0 and rows["head_yaw"].ratio == 0.0


def test_features_outside_the_contract_are_skipped() -> None:
    performer = stream(jaw_open=0.1 * np.sin(T), _neutral=np.sin(T))
    assert [row.name for row in compare(performer, performer)] == ["jaw_open"]


def test_streams_must_align() -> None:
    with pytest.raises(ValueError, match="200 performer frames but 199 robot frames"):
        compare(stream(jaw_open=T), stream(jaw_open=T[:-1]))
    with pytest.raises(ValueError, match="shape"):
        FeatureStream(("a", "b"), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="repeat"):
        FeatureStream(("a", "a"), np.zeros((3, 2)))


def test_from_frames_fills_gaps_with_nan() -> None:
    frames = [{"jaw_open": 0.1, "lips_part": 0.2}, None, {}, {"jaw_open": float("inf")}]
    built = FeatureStream.from_frames(frames)
    assert built.names == ("jaw_open", "lips_part")
    np.testing.assert_array_equal(built.values[0], [0.1, 0.2])
    assert np.isnan(built.values[1:]).all()
    fixed = FeatureStream.from_frames(frames, names=["lips_part", "head_yaw"])
    assert fixed.names == ("lips_part", "head_yaw")
    assert np.isnan(fixed.column("jaw_open")).all() and len(fixed) == 4


def test_reach_is_decided_across_the_profiles_of_one_head() -> None:
    wave = 0.1 * np.sin(T)  # a span of 0.2 IOD
    performer = stream(jaw_open=wave, lips_part=wave, lip_pucker=wave, head_yaw=50 * wave)
    weak = compare(
        performer,
        stream(jaw_open=wave, lips_part=0.05 * wave, lip_pucker=0.01 * wave, head_yaw=6 * wave),
    )
    strong = compare(
        performer,
        stream(jaw_open=wave, lips_part=0.5 * wave, lip_pucker=0.05 * wave, head_yaw=6 * wave),
    )
    weak_marked, strong_marked = mark_reach([weak, strong])
    reach = {row.name: row.reachable for row in weak_marked}
    # head_yaw: a ratio of 0.12, but 1.2 degrees is below half of the 3-degree threshold
    assert reach == {"jaw_open": True, "lips_part": True, "lip_pucker": False, "head_yaw": False}
    assert {row.name: row.reachable for row in strong_marked} == reach


def test_a_lag_compares_later_robot_frames() -> None:
    wave = 0.1 * np.sin(T)
    late = np.roll(wave, 4)  # the robot follows 4 frames late
    late[:4] = 0.0
    performer, robot = stream(jaw_open=wave, lips_part=wave), stream(jaw_open=late, lips_part=late)
    aligned = compare(performer, robot)[0]
    shifted = compare(performer, robot, lag=4)[0]
    assert shifted.rho == pytest.approx(1.0) and shifted.frames == N - 4
    assert aligned.rho < shifted.rho
    lag, rho = best_lag(performer, robot)
    assert lag == 4 and rho == pytest.approx(1.0)
    assert best_lag(performer, robot, max_lag=2)[0] == 2
    still = stream(jaw_open=np.zeros(N))
    assert best_lag(still, still)[0] == 0 and math.isnan(best_lag(still, still)[1])
    with pytest.raises(ValueError, match="a lag of 200 frames"):
        compare(performer, robot, lag=N)


def test_summary_over_moved_and_reachable_features() -> None:
    def row(
        name: str, rho: float, ratio: float, moved: bool = True, reach: bool = True
    ) -> FeatureRow:
        return FeatureRow(name, "u", 100, 1.0, ratio, rho, ratio, moved, reach)

    rows = [
        row("a", 0.9, 1.0),
        row("b", 0.7, 0.5),
        row("c", 0.8, 1.2),
        row("d", 0.0, 0.0, reach=False),
        row("e", -1.0, 3.0, moved=False),
    ]
    summary = summarize(rows)
    assert (summary.moved, summary.reachable) == (4, 3)
    assert summary.mean_rho == pytest.approx(0.8)
    assert summary.mean_rho_all == pytest.approx(0.6)
    assert summary.median_ratio == pytest.approx(1.0)
    assert summary.in_band == pytest.approx(2 / 3)
    empty = summarize([])
    assert empty.moved == 0 and math.isnan(empty.mean_rho) and math.isnan(empty.in_band)


def test_the_lead_is_over_what_the_performer_moves_and_the_robot_babbled() -> None:
    def row(name: str, rho: float, ratio: float, moved: bool, reach: bool) -> FeatureRow:
        return FeatureRow(name, "u", 100, 1.0, ratio, rho, ratio, moved, reach)

    rows = [
        row("a", 0.9, 1.0, moved=True, reach=True),  # moved, babbled, reached
        row("b", 0.1, 0.1, moved=True, reach=True),  # moved, reached, never babbled
        row("c", 0.5, 0.5, moved=True, reach=False),  # moved, babbled, no profile reached it
        row("d", -1.0, 3.0, moved=False, reach=True),  # babbled, the performer keeps it still
    ]
    babbled = {"a", "c", "d"}
    figures = lead(rows, babbled)
    assert figures.basis == "babbling" and figures.features == ("a", "c")
    assert figures.mean_rho == pytest.approx(0.7)
    assert figures.median_ratio == pytest.approx(0.75)
    assert figures.in_band == pytest.approx(0.5)
    reached = lead(rows, None)  # a head not babbled: what some profile reached
    assert reached.basis == "reach" and reached.features == ("a", "b")
    assert reached.mean_rho == pytest.approx(0.5)
    nothing = lead(rows, set())
    assert nothing.features == () and math.isnan(nothing.mean_rho)
    assert math.isnan(nothing.median_ratio) and math.isnan(nothing.in_band)


def test_the_ratio_in_reach_is_against_her_change_clipped_into_the_robots_reach() -> None:
    theirs = np.linspace(-1.0, 1.0, 101)  # span (p95 - p5) 1.8
    ours = np.clip(theirs, -0.2, 0.6)  # the robot follows her exactly where it can go
    assert span(ours) / span(theirs) == pytest.approx(0.8 / 1.8)  # the plain ratio: lost
    assert reach_ratio(theirs, ours, -0.2, 0.6) == pytest.approx(1.0)
    assert reach_ratio(theirs, 0.5 * ours, -0.2, 0.6) == pytest.approx(0.5)
    wide = reach_ratio(theirs, ours, -5.0, 5.0)  # a reach beyond hers: the plain ratio
    assert wide == pytest.approx(0.8 / 1.8)
    ours_gapped = ours.copy()
    ours_gapped[:50] = np.nan  # only the frames both sides have count
    assert reach_ratio(theirs, ours_gapped, -0.2, 0.6) == pytest.approx(1.0)
    # She moves only where the robot cannot go (below its neutral): not counted.
    assert math.isnan(reach_ratio(np.linspace(-1.0, 0.0, 50), np.zeros(50), 0.0, 0.5))
    assert math.isnan(reach_ratio(theirs, np.full(101, np.nan), -0.2, 0.6))


def test_compare_and_the_lead_take_the_ratio_in_reach_where_the_reach_is_known() -> None:
    wave = 0.1 * np.sin(T)
    performer = stream(jaw_open=wave, lips_part=wave, lip_pucker=wave)
    robot = stream(
        jaw_open=np.clip(wave, -0.05, 0.05),  # all the robot can: ratio 0.5, in reach 1
        lips_part=0.5 * np.clip(wave, 0.0, 0.1),  # half of what it can (one side)
        lip_pucker=np.full(N, np.nan),  # never seen: 0 where she moves within its reach
    )
    reach = {"jaw_open": (-0.05, 0.05), "lips_part": (0.0, 0.1), "lip_pucker": (-0.1, 0.1)}
    rows = by_name(compare(performer, robot, reach=reach))
    assert rows["jaw_open"].ratio == pytest.approx(0.5, abs=0.02)
    assert rows["jaw_open"].reach_ratio == pytest.approx(1.0)
    assert rows["lips_part"].reach_ratio == pytest.approx(0.5)
    assert rows["lip_pucker"].reach_ratio == 0.0
    figures = lead(list(rows.values()), {"jaw_open", "lips_part", "lip_pucker"})
    assert figures.median_reach_ratio == pytest.approx(0.5)
    unknown = compare(performer, robot, reach={"jaw_open": (-0.05, 0.05)})
    assert all(math.isnan(row.reach_ratio) for row in unknown if row.name != "jaw_open")
    assert math.isnan(lead(compare(performer, robot), None).median_reach_ratio)
