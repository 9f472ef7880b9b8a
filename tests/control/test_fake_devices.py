"""The fake boards follow their public protocol descriptions (so driver tests against them mean
something): bytes in, state and answers out, errors where the manuals say so."""

from __future__ import annotations

import os
from pathlib import Path

import serial
from fake_devices.maestro import PROTOCOL_ERROR, FakeMaestro
from fake_devices.ssc32 import VERSION, FakeSSC32


def test_maestro_compact_commands(tmp_path: Path) -> None:
    m = FakeMaestro(tmp_path / "m", channels=12)
    assert m.handle(bytes([0x84, 0x00, 0x70, 0x2E])) == b""  # 1500 us on channel 0
    assert m.handle(bytes([0x9F, 0x02, 0x03, 0x20, 0x1F, 0x70, 0x2E])) == b""
    assert m.handle(bytes([0x87, 0x05, 0x0C, 0x01, 0x89, 0x05, 0x04, 0x00])) == b""
    assert (
        m.positions_us()[0] == 1500 and m.positions_us()[3] == 1000 and m.positions_us()[4] == 1500
    )
    assert (m.speeds[5], m.accelerations[5]) == (140, 4)
    assert m.handle(bytes([0x90, 0x03])) == bytes([0xA0, 0x0F])  # 4000, low byte first
    assert m.handle(bytes([0xA1])) == b"\x00\x00"
    assert m.poses() == [{0: 1500.0, 3: 1000.0, 4: 1500.0}]


def test_maestro_protocol_errors_send_servos_to_their_error_state(tmp_path: Path) -> None:
    m = FakeMaestro(tmp_path / "m", channels=6)
    m.handle(bytes([0x84, 0x01, 0x70, 0x2E]))
    m.handle(bytes([0x84, 0x01, 0x70]) + bytes([0x84, 0x02, 0x70, 0x2E]))  # interrupted
    assert m.errors == PROTOCOL_ERROR and m.targets[1] == 0 and m.targets[2] == 6000
    assert m.handle(bytes([0xA1])) == bytes([PROTOCOL_ERROR, 0]) and m.errors == 0
    m.handle(bytes([0x9F, 0x01, 0x00, 0x70, 0x2E]))  # a Micro has no Set Multiple Targets
    assert m.errors == PROTOCOL_ERROR
    m.handle(bytes([0xA1]))
    m.handle(bytes([0x84, 0x06, 0x70, 0x2E]))  # no channel 6 on a Micro
    assert m.errors == PROTOCOL_ERROR
    m.handle(bytes([0xA1, 0x33]))  # a data byte outside any command
    assert m.errors == PROTOCOL_ERROR


def test_maestro_baud_indication_is_the_first_0xaa_only(tmp_path: Path) -> None:
    m = FakeMaestro(tmp_path / "m")
    m.handle(bytes([0xAA]))
    assert m.baud_detected and m.errors == 0
    m.handle(bytes([0xAA]))  # afterwards a Pololu-protocol packet this fake does not speak
    assert m.errors == PROTOCOL_ERROR


def test_ssc32_lines(tmp_path: Path) -> None:
    s = FakeSSC32(tmp_path / "s")
    assert s.handle(b"#5 P1600 #10 P750 T2500\r") == b""
    assert s.handle(b"#5p1500s750\r#17P750S500#2P2250T2000\r") == b""
    assert [m.widths for m in s.moves] == [{5: 1600, 10: 750}, {5: 1500}, {17: 750, 2: 2250}]
    assert s.moves[0].time_ms == 2500 and s.moves[1].speeds == {5: 750}
    assert s.handle(b"VER\r") == VERSION + b"\r"
    assert s.handle(b"Q\r") == b"."
    assert s.handle(b"QP 5\r") == bytes([150])
    assert s.handle(b"#40P1500\r#1P3000\rXYZ\r") == b""
    assert s.ignored == ["#40P1500", "#1P3000", "XYZ"] and len(s.moves) == 3


def test_unplug_makes_the_port_vanish_and_plug_brings_it_back(tmp_path: Path) -> None:
    s = FakeSSC32(tmp_path / "s")
    s.plug()
    try:
        port = serial.Serial(str(s.link), 115200, timeout=1)
        port.write(b"VER\r")
        assert port.read(len(VERSION) + 1) == VERSION + b"\r"
        s.unplug()
        assert not s.link.exists()
        try:
            data = port.read(1)
        except serial.SerialException:
            data = None
        assert not data  # hung up
        port.close()
        s.plug()
        assert os.path.exists(s.link) and s.end.plugs == 2
        with serial.Serial(str(s.link), 115200, timeout=1) as again:
            again.write(b"Q\r")
            assert again.read(1) == b"."
    finally:
        s.close()
