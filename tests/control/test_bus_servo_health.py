"""bus_servo/health.py: what the read-backs say of each servo (faults, misses, silence)."""

from __future__ import annotations

from facesynth.services.control.drivers.bus_servo.bus import Status
from facesynth.services.control.drivers.bus_servo.health import (
    MISSES,
    NOT_ANSWERING,
    REPROBE_S,
    SILENT_S,
    ServoHealth,
)

OK = Status(position=2048, load=0.1, temperature_c=30.0)
HOT = Status(position=2048, load=0.1, temperature_c=80.0, fault="overheating")


def test_a_servo_is_not_answering_only_after_misses_in_a_row() -> None:
    health = ServoHealth()
    health.connected({}, [1, 2], now=0.0)
    for k in range(1, MISSES):
        assert health.update({1: None, 2: OK}, now=k) == []
    assert health.update({1: None, 2: OK}, now=MISSES) == [(1, "", NOT_ANSWERING)]
    assert health.faults == {1: NOT_ANSWERING}
    assert health.update({1: OK}, now=MISSES + 1) == [(1, NOT_ANSWERING, "")]
    assert health.faults == {} and health.statuses[1] == OK


def test_an_answer_resets_the_misses() -> None:
    health = ServoHealth()
    health.connected({}, [1], now=0.0)
    for k in range(3 * MISSES):
        answer = OK if k % MISSES == MISSES - 1 else None
        assert health.update({1: answer}, now=k) == []


def test_a_reported_fault_is_kept_until_it_clears() -> None:
    health = ServoHealth()
    health.connected({3: "overload"}, [3], now=0.0)
    assert health.update({3: None}, now=1.0) == []  # a miss does not clear it
    assert health.update({3: HOT}, now=2.0) == [(3, "overload", "overheating")]
    assert health.update({3: OK}, now=3.0) == [(3, "overheating", "")]


def test_a_servo_not_answering_is_asked_again_once_a_second() -> None:
    health = ServoHealth()
    health.connected({}, [1, 2, 3], now=0.0)
    for k in range(MISSES):
        health.update({2: None}, now=10.0 + k * 0.01)
    last = 10.0 + (MISSES - 1) * 0.01
    assert health.pick([1, 2, 3], turn=0, size=3, now=last + REPROBE_S / 2) == [1, 3]
    assert health.pick([1, 2, 3], turn=0, size=3, now=last + REPROBE_S) == [1, 2, 3]
    assert health.pick([1, 2, 3], turn=1, size=2, now=last) == [3, 1]  # round robin


def test_a_bus_is_silent_when_no_servo_answered_for_a_while() -> None:
    health = ServoHealth()
    assert not health.silent(100.0)  # never connected: nothing to judge
    health.connected({}, [1, 2], now=0.0)
    health.update({1: OK}, now=1.0)
    assert not health.silent(1.0 + SILENT_S)
    assert health.silent(1.0 + SILENT_S + 0.01)
