"""facesynth.services.control.neutral_return: the watchdog that says the commands stopped, and
the ramp that takes the face back to neutral in even steps."""

from __future__ import annotations

import math

import pytest

from facesynth.services.control.neutral_return import RAMP_RATE_HZ, Ramp, Watchdog

MS = 1_000_000


def test_watchdog_is_quiet_before_the_first_command() -> None:
    dog = Watchdog(0.5)
    assert [dog.expired(t * 1000 * MS) for t in range(10)] == [False] * 10


def test_watchdog_fires_exactly_once_per_silence() -> None:
    dog = Watchdog(0.5)
    dog.feed(1000 * MS)
    assert dog.expired(1000 * MS) is False
    assert dog.expired(1499 * MS) is False
    assert dog.expired(1500 * MS) is True  # exactly the timeout
    assert [dog.expired((1500 + i * 100) * MS) for i in range(1, 20)] == [False] * 19
    dog.feed(5000 * MS)  # commands are back
    assert dog.expired(5400 * MS) is False
    assert dog.expired(5600 * MS) is True  # the next silence fires again, once
    assert dog.expired(9000 * MS) is False


def test_feeding_keeps_the_watchdog_quiet() -> None:
    dog = Watchdog(0.1)
    fired = []
    for i in range(50):  # a command every 40 ms
        dog.feed(i * 40 * MS)
        fired.append(dog.expired(i * 40 * MS + 39 * MS))
    assert not any(fired)
    assert dog.expired(49 * 40 * MS + 100 * MS) is True


@pytest.mark.parametrize("timeout", [0.0, -1.0, math.nan], ids=["zero", "negative", "nan"])
def test_watchdog_timeout_must_be_positive(timeout: float) -> None:
    with pytest.raises(ValueError, match="the watchdog timeout must be positive"):
        Watchdog(timeout)


# --- Ramp -------------------------------------------------------------------------------------


def test_a_ramp_takes_rate_times_its_length_in_steps_and_at_least_one() -> None:
    assert Ramp.begin(0, 1.0, {}).steps == RAMP_RATE_HZ
    assert Ramp.begin(0, 0.2, {}).steps == 5
    assert Ramp.begin(0, 0.0, {}).steps == 1  # no ramp: one step straight to neutral
    assert Ramp.begin(7, 0.5, {}).ramp_ns == 500 * MS


def test_a_ramp_steps_evenly_in_time_and_in_position_to_neutral_exactly() -> None:
    ramp = Ramp.begin(1000 * MS, 0.2, {"jaw": 2000.0, "brow": 900.0})
    neutral = {"jaw": 1500.0, "brow": 1500.0, "lip": 1400.0}  # lip was not moving: not stepped
    dues, targets = [], []
    while (due := ramp.due_ns()) is not None:
        dues.append(due)
        targets.append(ramp.step(neutral))
    assert dues == [(1000 + 40 * i) * MS for i in range(1, 6)]
    assert [t["jaw"] for t in targets] == [1900.0, 1800.0, 1700.0, 1600.0, 1500.0]
    assert [t["brow"] for t in targets] == [1020.0, 1140.0, 1260.0, 1380.0, 1500.0]
    assert all(t.keys() == {"jaw", "brow"} for t in targets)
    assert ramp.due_ns() is None and ramp.done == ramp.steps == 5
