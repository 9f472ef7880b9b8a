"""The phase lead on a learned profile's commands (services/translator/lead.py): a command
moving at a steady rate is asked for ``lead_s`` ahead, a still one is left as it is, and a
first sample, a gap or a time going back start afresh."""

from __future__ import annotations

import numpy as np
import pytest

from facesynth.services.translator.lead import PhaseLead

FRAME_NS = 33_333_333


def test_a_steady_ramp_is_asked_for_lead_s_ahead() -> None:
    lead = PhaseLead(0.1)
    rate = np.array([1.5, -0.6])  # normalized units per second
    out = np.zeros(2)
    for index in range(60):  # two seconds: the rate's low-pass has settled
        t_ns = index * FRAME_NS
        out = lead(rate * t_ns / 1e9, t_ns)
    assert out - rate * 59 * FRAME_NS / 1e9 == pytest.approx(0.1 * rate, rel=1e-3)


def test_a_still_command_is_left_as_it_is() -> None:
    lead = PhaseLead(0.1)
    u = np.array([0.3, -0.2, 0.0])
    for index in range(30):
        assert lead(u, index * FRAME_NS) == pytest.approx(u, abs=1e-12)


def test_the_first_sample_passes_through_and_its_rate_is_low_passed() -> None:
    lead = PhaseLead(0.1, cutoff_hz=10.0)
    assert lead(np.array([0.0]), 0)[0] == 0.0
    step = lead(np.array([0.5]), FRAME_NS)[0]  # a jump: a rate of 15/s, a part of it leads
    assert 0.5 < step < 0.5 + 0.1 * 15.0
    assert step == pytest.approx(0.5 + 0.1 * 15.0 * (1 / (1 + 1 / (2 * np.pi * 10 / 30))), 1e-3)


@pytest.mark.parametrize(
    ("label", "next_ns"),
    [("a gap of a second", 1_000_000_000 + FRAME_NS), ("time going back", FRAME_NS // 2)],
)
def test_a_gap_or_time_going_back_starts_afresh(label: str, next_ns: int) -> None:
    lead = PhaseLead(0.1)
    lead(np.array([0.0]), 0)
    lead(np.array([0.5]), FRAME_NS)  # moving fast
    assert lead(np.array([0.9]), next_ns)[0] == 0.9, label  # no stale rate, no kick


def test_the_same_instant_again_is_led_by_the_rate_known() -> None:
    lead = PhaseLead(0.1)
    lead(np.array([0.0]), 0)
    first = lead(np.array([0.5]), FRAME_NS)[0]
    assert lead(np.array([0.5]), FRAME_NS)[0] == first


def test_reset_forgets_the_rate() -> None:
    lead = PhaseLead(0.1)
    lead(np.array([0.0]), 0)
    lead(np.array([0.5]), FRAME_NS)
    lead.reset()
    assert lead(np.array([0.6]), 2 * FRAME_NS)[0] == 0.6


@pytest.mark.parametrize("arguments", [(-0.1,), (float("nan"),), (0.1, 0.0), (0.1, 10.0, 0.0)])
def test_bad_parameters_are_refused(arguments: tuple[float, ...]) -> None:
    with pytest.raises(ValueError, match="a phase lead needs"):
        PhaseLead(*arguments)
