"""``facesynth bench drivers``: bytes and wire time of one pose per driver."""

from __future__ import annotations

import re

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


def test_smart_bus_frames_fit_three_ms_at_one_mbps() -> None:
    """Issue 26's goal: 16 servos, Sync Write plus read-back <= 3 ms of bus time a frame at
    1 Mbps, from the bytes the vendors' SDKs write and the status packets' sizes."""
    from facesynth.app.bench.bus_time import bus_frames
    from facesynth.runtime.profiles import load_profile

    frames = {(f.driver, f.how): f for f in bus_frames(load_profile("paper16"))}
    x = frames["dynamixel", "2.0 XL430, Sync Read"]
    # Sync Write: header 7 + INST + address 2 + length 2 + CRC 2 + 16 x (id + 4 bytes)
    assert (x.write_bytes, x.request_bytes) == (14 + 16 * 5, 14 + x.servos_read)
    assert x.answer_bytes == x.servos_read * (11 + 21) and x.servos_read == 5
    sts = frames["feetech", "STS3215, Sync Read"]
    assert sts.write_bytes == 8 + 16 * 3 and sts.answer_bytes == sts.servos_read * 14
    for frame in frames.values():
        if frame.baud == 1000000:
            assert frame.bus_ms <= 3.0, frame
    assert frames["dynamixel", "2.0 XL430, factory 57600"].bus_ms > 20


def test_emulated_runs_measure_cpu_and_the_bytes_on_the_bus() -> None:
    """``--emulated``: each driver drives its emulator (another process, on a pty) and the
    emulator counts the bytes both ways; a smart bus frame with a read-back measures what the
    packet sizes say, within issue 26's 3 ms at 1 Mbps."""
    from facesynth.app.bench.driver_cpu import CASES, bench_cpu, format_cpu
    from facesynth.runtime.profiles import load_profile

    profile = load_profile("paper16")
    cases = tuple(c for c in CASES if c.label in ("maestro", "dynamixel 2.0", "feetech"))
    runs = bench_cpu(profile, frames=45, fps=30, repeat=1, cases=cases)
    maestro, dxl, sts = (case_runs[0] for case_runs in runs)
    assert all(run.cpu_ms > 0 for run in (maestro, dxl, sts))
    # Set Multiple Targets a frame (and now and then Get Errors: one byte out, two back)
    assert 3 + 2 * 16 <= maestro.bytes_out < 36 and maestro.bytes_back < 1
    for bus, write, request, answers in (
        (dxl, 14 + 16 * 5, 14 + 5, 5 * (11 + 21)),
        (sts, 8 + 16 * 3, 8 + 12, 12 * (6 + 8)),
    ):
        assert bus.read_frames >= 10, bus  # about 15 read-backs a second
        # (the largest may hold several poses a stalled sender sent together)
        assert bus.read_frame_bytes == write + request + answers <= bus.read_frame_max
        assert bus.read_frame_ms is not None and bus.computed_ms is not None
        assert bus.read_frame_ms[0] == pytest.approx(bus.computed_ms) and bus.computed_ms <= 3.0
    table = format_cpu(profile, runs, 30)
    assert "C's CPU per frame, measured: 16 servos of profile paper16, 45 frames" in table
    assert re.search(r"dynamixel 2.0 .* 2\.73/\d+\.\d\d +2\.73 +5\n", table), table


def test_emulated_runs_need_a_source_checkout(monkeypatch: pytest.MonkeyPatch) -> None:
    from facesynth.app.bench import driver_cpu
    from facesynth.app.wiring import OptionError

    monkeypatch.setattr(driver_cpu, "FAKE_DEVICES", driver_cpu.FAKE_DEVICES / "nowhere")
    with pytest.raises(OptionError, match="run it from a clone of facesynth"):
        driver_cpu.check_options(frames=10, fps=30, repeat=1)
