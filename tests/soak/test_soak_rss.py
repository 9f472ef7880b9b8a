"""RSS series -> steps and slopes (tools/soak/rss.py), from data."""

from __future__ import annotations

import pytest

from tools.soak.rss import Incarnation, Sample, process_figures, slope, steps


def series(start_s: float, values: list[float], every_s: float = 10.0) -> list[Sample]:
    return [Sample(start_s + i * every_s, mb) for i, mb in enumerate(values)]


def test_a_rise_between_two_samples_is_a_step_and_consecutive_rises_are_one() -> None:
    found = steps(series(0, [60, 60.5, 70, 75, 75.2, 75.1, 89, 89]))
    assert [(s.before_mb, s.after_mb) for s in found] == [(60.5, 75), (75.1, 89)]
    assert [(s.start_s, s.end_s) for s in found] == [(10, 30), (50, 60)]
    assert found[0].rise_mb == 14.5


def test_small_rises_are_not_steps() -> None:
    assert steps(series(0, [60, 61.5, 63, 64.5, 66])) == []


def test_the_slope_is_a_least_squares_fit_in_mb_per_hour() -> None:
    # 1 MB an hour, sampled every 10 s for 10 min, with noise that cancels out.
    values = [60 + i * 10 / 3600 + (0.2 if i % 2 else -0.2) for i in range(61)]
    fit = slope(series(0, values))
    assert fit is not None
    assert fit.mb_per_hour == pytest.approx(1.0, abs=0.1)
    assert (fit.start_s, fit.span_s, fit.samples) == (0, 600, 61)


def test_a_series_too_short_has_no_slope() -> None:
    assert slope(series(0, [60, 61, 62])) is None
    assert slope(series(0, [60] * 10, every_s=5)) is None  # 45 s


def test_the_slope_is_fitted_after_the_last_step_and_the_warm_up() -> None:
    # Warm-up growth (first minute), a flat run, a step of 19 MB, then flat again: no slope
    # but the step, where a fit over everything would say hundreds of MB an hour.
    values = [30, 45, 55, 60, 60, 60, 60] + [60] * 20 + [79] + [79] * 20
    figures = process_figures("router", [Incarnation("router", 1, series(0, values))])
    (inc,) = figures.incarnations
    assert [(s.before_mb, s.after_mb) for s in inc.steps] == [(60, 79)]
    assert inc.slope is not None and inc.slope.mb_per_hour == pytest.approx(0.0, abs=1e-9)
    assert inc.slope.start_s == 270  # the first sample after the step
    assert (inc.first_mb, inc.last_mb, inc.peak_mb) == (30, 79, 79)


def test_each_incarnation_is_fitted_alone_and_the_longest_fit_speaks_for_the_process() -> None:
    first = Incarnation("points", 10, series(0, [100 + i * 0.01 for i in range(40)]))
    second = Incarnation("points", 11, series(400, [90 + i * 0.05 for i in range(80)]))
    figures = process_figures("points", [first, second])
    assert [inc.pid for inc in figures.incarnations] == [10, 11]
    assert figures.slope is not None
    assert figures.slope.mb_per_hour == pytest.approx(0.05 * 360, rel=1e-6)  # the second's
    assert figures.incarnations[0].slope is not None
    assert figures.incarnations[0].slope.mb_per_hour == pytest.approx(3.6, rel=1e-6)


def test_rss_per_hour_spans_incarnations() -> None:
    first = Incarnation("control", 1, series(0, [60, 61, 62], every_s=1800))  # 0, 0.5, 1 h
    second = Incarnation("control", 2, series(5400, [50, 70], every_s=1800))  # 1.5, 2 h
    hours = process_figures("control", [first, second]).hours
    assert [(h.hour, h.first_mb, h.last_mb, h.peak_mb) for h in hours] == [
        (0, 60, 61, 61),
        (1, 62, 50, 62),
        (2, 70, 70, 70),
    ]


def test_an_incarnation_without_samples_is_left_out() -> None:
    figures = process_figures("sensor", [Incarnation("sensor", 3)])
    assert figures.incarnations == [] and figures.slope is None and figures.steps == []
