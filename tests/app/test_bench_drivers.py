"""``facesynth bench drivers``: bytes and wire time of one pose per driver."""

from __future__ import annotations

import pytest

from facesynth.app.bench.drivers import bench_drivers
from facesynth.app.cli import main


def test_wire_costs_of_a_sixteen_servo_pose() -> None:
    _, costs = bench_drivers("paper16")
    by_how = {(c.driver, c.how): c for c in costs}
    arduino = by_how["arduino", "SET_ALL, CRC, ACK back"]
    assert (arduino.frame_bytes, arduino.reply_bytes) == (39, 10)  # PROTOCOL.md: 32 + 7
    assert arduino.wire_ms == pytest.approx(39 * 10 / 115200 * 1000)
    assert by_how["maestro", "Mini: Set Multiple Targets"].frame_bytes == 3 + 2 * 16
    assert by_how["maestro", "Micro/auto: Set Target each"].frame_bytes == 4 * 16
    plain = by_how["ssc32", "group move"]
    assert plain.frame_bytes == len("".join(f"#{ch}P1234" for ch in range(16))) + 1
    slow = by_how["ssc32", "group move, S, factory 9600"]
    assert slow.wire_ms > 150 and slow.poses_per_s < 6
    assert all(c.encode_us > 0 for c in costs)


def test_the_command_prints_the_table(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "drivers"]) == 0
    out = capsys.readouterr().out
    assert "one pose of profile paper16 (16 servos), per driver" in out
    assert "arduino  SET_ALL, CRC, ACK back       115200    39   10     3.39      295" in out
