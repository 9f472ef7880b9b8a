"""The head's pure core: slew, lag, dead band, clamping, curves, coupling, time as data."""

from __future__ import annotations

import math

import pytest

from facesynth.app.simhead import Actuator, HeadConfig, SimHead, load_head, response

MS = 1_000_000


def head(**fields: object) -> SimHead:
    actuator = Actuator(name="a", channel=2, effects={"jaw": 1.0}, **fields)  # type: ignore[arg-type]
    return SimHead(HeadConfig(name="t", actuators=[actuator]))


def test_at_power_up_every_actuator_rests() -> None:
    sim = SimHead(load_head("simhead16"))
    assert sim.pulses() == {}
    assert sim.positions() == {a.channel: a.rest_us for a in sim.config.actuators}
    assert all(value == 0.0 for value in sim.outputs().values())
    assert all(value == 0.0 for value in sim.activations().values())
    sim.step(5_000 * MS)  # no pulses: nothing moves
    assert sim.positions()[0] == sim.config.by_channel()[0].rest_us


def test_slew_limits_the_horn() -> None:
    sim = head(slew_us_per_s=1000.0, lag_s=0.0)
    sim.command(2, 2000)
    sim.step(100 * MS)
    assert sim.positions()[2] == pytest.approx(1600.0)  # 1000 µs/s for 0.1 s
    assert sim.moving()
    sim.step(600 * MS)
    assert sim.positions()[2] == pytest.approx(2000.0)
    assert not sim.moving()


def test_the_skin_lags_the_horn() -> None:
    sim = head(slew_us_per_s=1e6, lag_s=0.1)
    sim.command(2, 1900)
    sim.step(100 * MS)  # the horn is there at once; the skin one time constant behind
    assert sim.positions()[2] == pytest.approx(1500 + 400 * (1 - math.exp(-1.0)), abs=0.5)
    sim.step(1_000 * MS)
    assert sim.positions()[2] == pytest.approx(1900, abs=0.1)


def test_steps_of_any_size_agree() -> None:
    fine, coarse = head(slew_us_per_s=1e6, lag_s=0.05), head(slew_us_per_s=1e6, lag_s=0.05)
    for sim in (fine, coarse):
        sim.command(2, 1200)
    for i in range(1, 11):
        fine.step(i * 10 * MS)
    coarse.step(100 * MS)
    assert fine.positions()[2] == pytest.approx(coarse.positions()[2])


def test_pulses_are_clamped_to_the_actuators_range() -> None:
    sim = head(min_us=1100.0, max_us=1800.0, slew_us_per_s=1e6)
    sim.command(2, 2400)
    sim.step(1_000 * MS)
    assert sim.positions()[2] == pytest.approx(1800.0)
    assert sim.pulses() == {2: 2400.0}  # what was commanded
    sim.command(2, 600)
    sim.step(2_000 * MS)
    assert sim.positions()[2] == pytest.approx(1100.0)


def test_pulses_off_leave_the_actuator_where_it_is() -> None:
    sim = head(slew_us_per_s=1000.0)
    sim.command(2, 2000)
    sim.step(200 * MS)
    sim.command(2, 0)
    sim.step(2_000 * MS)
    assert sim.positions()[2] == pytest.approx(1700.0)
    assert sim.pulses() == {2: 0.0}


def test_the_dead_band_and_the_curves() -> None:
    linear = Actuator(name="a", channel=0, rest_us=1500.0, dead_band_us=50.0)
    assert response(linear, 1540) == 0.0
    assert response(linear, 1460) == 0.0
    assert response(linear, 1550 + 225) == pytest.approx(0.5)
    assert response(linear, 2000) == pytest.approx(1.0)
    assert response(linear, 1000) == pytest.approx(-1.0)
    power = Actuator(name="a", channel=0, curve="power", exponent=2.0, gain_down=0.5)
    assert response(power, 1750) == pytest.approx(0.25)
    assert response(power, 1250) == pytest.approx(-0.125)  # the other side's gain
    smooth = Actuator(name="a", channel=0, curve="smoothstep", reversed=True)
    assert response(smooth, 1750) == pytest.approx(-0.5)
    assert response(smooth, 1600) == pytest.approx(-(0.2**2) * (3 - 0.4))
    offset = Actuator(name="a", channel=0, rest_us=1600.0)
    assert response(offset, 1500) == pytest.approx(-100 / 600)
    assert response(offset, 1800) == pytest.approx(0.5)


def test_effects_and_coupling() -> None:
    actuator = Actuator(
        name="a",
        channel=0,
        slew_us_per_s=1e6,
        effects={"jaw": 0.8, "lip_pucker": -0.5},
        coupling={"lip_corner_left": 0.4},
    )
    other = Actuator(name="b", channel=1, slew_us_per_s=1e6, effects={"jaw": 0.1})
    sim = SimHead(HeadConfig(name="t", actuators=[actuator, other]))
    sim.command(0, 1250)  # output -0.5
    sim.command(1, 2000)  # output +1
    sim.command(7, 1700)  # no actuator: kept, moves nothing
    sim.step(10 * MS)
    assert sim.activations() == pytest.approx(
        {"jaw": -0.4 + 0.1, "lip_pucker": 0.25, "lip_corner_left": -0.1}
    )
    assert sim.pulses() == {0: 1250.0, 1: 2000.0, 7: 1700.0}


def test_bad_commands_and_time() -> None:
    sim = head()
    with pytest.raises(ValueError, match=r"channel 24 is not within 0\.\.23"):
        sim.command(24, 1500)
    with pytest.raises(ValueError, match="not a pulse"):
        sim.command(2, math.nan)
    with pytest.raises(ValueError, match="not a pulse"):
        sim.command(2, -5)
    sim.step(10 * MS)
    with pytest.raises(ValueError, match="time went back"):
        sim.step(5 * MS)
    assert sim.t_ns == 10 * MS
