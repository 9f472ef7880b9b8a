"""The Uno servo firmware on an emulated ATmega328P + PCA9685 (simavr), driven over its pty.

Times asserted here are emulated (the harness stamps events with the AVR's cycle counter);
wall-clock timeouts only bound how long a test waits.
"""

from __future__ import annotations

import itertools
import statistics
from pathlib import Path

import pytest
from uno_emulator import EmulatedUno, Pulse

from facesynth.services.control.drivers.arduino import protocol as proto
from facesynth.services.control.drivers.arduino import replies

pytestmark = pytest.mark.firmware

TICK_US = 122 / 25  # PCA9685 at PRE_SCALE 121: 4.88 us per step
NEUTRAL = proto.US_DEFAULT_NEUTRAL


def near(width: float, us: float) -> bool:
    """A PCA9685 width is the request rounded to the nearest tick (the firmware's fixed-point
    conversion may miss exact rounding by 0.002 tick)."""
    return abs(width - us) <= TICK_US / 2 + 0.02


def settle(uno: EmulatedUno, want: dict[int, float]) -> None:
    """Wait until every channel in ``want`` shows its width (to within a tick step)."""
    uno.wait_for(lambda: all(near(uno.widths().get(ch, -1), us) for ch, us in want.items()))


def ack(reply: replies.Reply, cmd: str, clamped: int = 0) -> None:
    assert isinstance(reply, replies.Ack), reply
    assert reply.cmd == proto.COMMANDS[cmd].code
    assert reply.clamped == clamped


def nack(reply: replies.Reply, cmd: str, error: proto.ErrorCode) -> None:
    assert isinstance(reply, replies.Nack), reply
    assert (reply.cmd, reply.error) == (proto.COMMANDS[cmd].code, error)


def test_boot_ping_and_pca9685_setup(booted_uno: EmulatedUno) -> None:
    uno = booted_uno
    version = uno.wait_ready()
    assert (version.protocol, version.channels, version.output) == (1, 16, proto.OutputKind.PCA9685)
    assert version.max_payload == proto.MAX_PAYLOAD
    regs = [(name, int(value, 16)) for _, name, value in uno.events("reg")]
    # PRE_SCALE 121 (50 Hz) written while asleep with auto-increment, then woken up.
    assert regs[:4] == [("MODE1", 0x30), ("PRE_SCALE", 121), ("MODE2", 0x04), ("MODE1", 0x20)]
    assert uno.events("warn") == []
    assert uno.widths() == {ch: pytest.approx(1498.16, abs=0.01) for ch in range(16)}
    status = uno.status()
    assert status.flags == proto.Flags(0) and status.frames_ok >= 1
    assert status.watchdog_ms == proto.WATCHDOG_DEFAULT_MS


def test_set_all_sixteen_channels(uno: EmulatedUno) -> None:
    want = {ch: 1010 + 61 * ch for ch in range(16)}  # 1010..1925, distinct
    ack(uno.request(proto.set_all(uno.next_seq(), list(want.values()))), "SET_ALL")
    settle(uno, want)
    staggered = {}
    for ch, us in want.items():
        assert near(uno.widths()[ch], us), (ch, uno.widths()[ch], us)
        staggered[ch] = uno.widths()[ch]
    set_some = {3: 1500, 9: 1234}
    ack(uno.request(proto.set_some(uno.next_seq(), set_some)), "SET_SOME")
    settle(uno, set_some)
    assert uno.widths() == {
        **staggered,
        **{ch: pytest.approx(us, abs=2.5) for ch, us in set_some.items()},
    }


def test_clamps_to_default_limits(uno: EmulatedUno) -> None:
    positions = [600, 2400, 0, 65535] + [1500] * 12
    ack(uno.request(proto.set_all(uno.next_seq(), positions)), "SET_ALL", clamped=4)
    settle(uno, {0: 1000, 1: 2000, 2: 1000, 3: 2000})
    assert uno.status().clamped == 4


def test_limits_then_out_of_range_commands_clamp(uno: EmulatedUno) -> None:
    limits = {0: proto.Limits(800, 1200, 2200), 5: proto.Limits(1400, 1450, 1500)}
    ack(uno.request(proto.set_limits(uno.next_seq(), limits)), "SET_LIMITS")
    ack(uno.request(proto.set_some(uno.next_seq(), {0: 700, 5: 2300, 6: 2300})), "SET_SOME", 3)
    settle(uno, {0: 800, 5: 1500, 6: 2000})
    ack(uno.request(proto.set_some(uno.next_seq(), {0: 2300, 5: 1000})), "SET_SOME", 2)
    settle(uno, {0: 2200, 5: 1400})
    ack(uno.request(proto.neutral(uno.next_seq())), "NEUTRAL")
    settle(uno, {0: 1200, 5: 1450, 6: NEUTRAL})
    status = uno.status()
    assert status.flags & proto.Flags.LIMITS_SET and status.clamped == 5
    # Limits the firmware refuses change nothing.
    bad = {1: proto.Limits(400, 1500, 2000)}
    assert bad[1].problems()
    nack(
        uno.request(proto.set_limits(uno.next_seq(), bad)), "SET_LIMITS", proto.ErrorCode.BAD_VALUE
    )
    ack(uno.request(proto.set_some(uno.next_seq(), {1: 900})), "SET_SOME", 1)
    settle(uno, {1: 1000})


def watchdog_delay_ms(uno: EmulatedUno) -> float:
    """Send one SET_ALL, wait for the watchdog: emulated ms from the command to neutral."""
    before = len(uno.pulses())
    sent = uno.write(proto.set_all(uno.next_seq(), [1800] * 16))

    def back_at_neutral() -> list[Pulse]:
        return [p for p in uno.pulses()[before:] if near(p.width_us, NEUTRAL)]

    uno.wait_for(lambda: len(back_at_neutral()) == 16)
    moved = [p for p in uno.pulses()[before:] if near(p.width_us, 1800)]
    assert len(moved) == 16
    back = back_at_neutral()
    assert max(p.t_us for p in back) - min(p.t_us for p in back) < 3000  # three I2C writes
    return (min(p.t_us for p in back) - uno.rx_time_us(sent)) / 1000


def test_watchdog_returns_to_neutral_after_timeout(booted_uno: EmulatedUno) -> None:
    uno = booted_uno
    # Neutral comes timeout_ms after the last command, to within millis()'s resolution: its
    # ticks are 1.024 ms and a reading lags true time by up to about one tick.
    delay = watchdog_delay_ms(uno)
    print(f"\nwatchdog 500 ms: first channel at neutral {delay:.2f} ms after the command")
    assert proto.WATCHDOG_DEFAULT_MS - 1.1 <= delay <= proto.WATCHDOG_DEFAULT_MS + 3, delay
    ack(uno.request(proto.set_watchdog(uno.next_seq(), 150)), "SET_WATCHDOG")
    delay = watchdog_delay_ms(uno)
    print(f"watchdog 150 ms: first channel at neutral {delay:.2f} ms after the command")
    assert 150 - 1.1 <= delay <= 150 + 3, delay
    status = uno.status()
    assert status.watchdog_trips == 2 and status.watchdog_ms == 150
    assert not status.flags & proto.Flags.WATCHDOG_ARMED


def test_bad_frames_change_nothing_and_are_counted(uno: EmulatedUno) -> None:
    ack(uno.request(proto.set_all(uno.next_seq(), [1300] * 16)), "SET_ALL")
    settle(uno, dict.fromkeys(range(16), 1300))
    pulses_before = len(uno.pulses())
    applied = uno.seq
    moving = proto.set_all(uno.next_seq(), [1700] * 16)

    corrupt = bytearray(moving)
    corrupt[10] ^= 0x04  # a flipped bit in a position
    uno.write(bytes(corrupt))
    uno.write(b"\x00\x13\x37garbage\xff")  # bytes outside any frame
    uno.write(moving[:20])  # cut off, then silence
    uno.read_replies(0.3)  # > 50 ms of silence (emulation runs at about real time)
    uno.write(bytes([proto.START, proto.MAX_PAYLOAD + 1]) + bytes(40))  # oversized LEN
    reply = uno.request(proto.encode_frame(uno.next_seq(), 0x7E))
    assert isinstance(reply, replies.Nack) and reply.error == proto.ErrorCode.UNKNOWN_COMMAND
    short = proto.encode_frame(uno.next_seq(), proto.COMMANDS["SET_ALL"].code, bytes(30))
    nack(uno.request(short), "SET_ALL", proto.ErrorCode.BAD_LENGTH)
    bad_channel = proto.encode("SET_SOME", uno.next_seq(), [(2, 1700), (16, 1700)])
    nack(uno.request(bad_channel), "SET_SOME", proto.ErrorCode.BAD_CHANNEL)
    replayed = proto.set_all(applied, [1700] * 16)
    nack(uno.request(replayed), "SET_ALL", proto.ErrorCode.STALE_SEQUENCE)

    status = uno.status()
    assert status.crc_errors == 1
    assert status.truncated == 1
    assert status.bad_length == 2  # oversized LEN, and 30 bytes for SET_ALL
    assert status.unknown_command == 1
    assert status.bad_value == 1
    assert status.stale_sequence == 1
    assert status.dropped_bytes > 0
    assert status.last_seq == applied
    assert uno.pulses()[pulses_before:] == []  # no servo moved
    assert uno.widths() == dict.fromkeys(range(16), pytest.approx(1300, abs=2.5))


def test_sequence_wraps_around(booted_uno: EmulatedUno) -> None:
    uno = booted_uno  # no command applied yet: the first SEQ may be anything
    ack(uno.request(proto.set_watchdog(65533, proto.WATCHDOG_MAX_MS)), "SET_WATCHDOG")
    ack(uno.request(proto.set_all(65534, [1100] * 16)), "SET_ALL")
    nack(uno.request(proto.set_all(65534, [1900] * 16)), "SET_ALL", proto.ErrorCode.STALE_SEQUENCE)
    ack(uno.request(proto.set_all(1, [1200] * 16)), "SET_ALL")  # 65534 -> 1 wraps: newer
    nack(uno.request(proto.set_all(65535, [1900] * 16)), "SET_ALL", proto.ErrorCode.STALE_SEQUENCE)
    settle(uno, dict.fromkeys(range(16), 1200))
    assert not any(near(p.width_us, 1900) for p in uno.pulses())
    assert uno.status().last_seq == 1


def test_rate_limited_channel(uno: EmulatedUno) -> None:
    ack(
        uno.request(proto.set_limits(uno.next_seq(), {4: proto.Limits(1000, 1500, 2000, 20)})),
        "SET_LIMITS",
    )
    before = len(uno.pulses())
    ack(uno.request(proto.set_some(uno.next_seq(), {4: 1700, 5: 1700})), "SET_SOME")
    settle(uno, {4: 1700, 5: 1700})
    ch4 = [p for p in uno.pulses()[before:] if p.channel == 4]
    ch5 = [p for p in uno.pulses()[before:] if p.channel == 5]
    assert len(ch5) == 1  # no rate limit: one jump
    assert len(ch4) == 10  # 200 us in steps of 20 us
    steps = [b.width_us - a.width_us for a, b in itertools.pairwise(ch4)]
    assert all(0 < s <= 20 + TICK_US for s in steps), steps
    gaps_ms = [(b.t_us - a.t_us) / 1000 for a, b in itertools.pairwise(ch4)]
    assert all(19 <= g <= 22 for g in gaps_ms), gaps_ms


def test_command_to_pulse_latency(uno: EmulatedUno) -> None:
    """From the last byte of a SET_ALL in the UART to the PCA9685 latching channel 0 / all 16."""
    first, last = [], []
    for i in range(20):
        us = 1100 + 37 * i
        before = len(uno.pulses())
        sent = uno.write(proto.set_all(uno.next_seq(), [us] * 16))
        uno.wait_for(lambda: len(uno.pulses()) - before >= 16)  # noqa: B023
        t_rx = uno.rx_time_us(sent)
        changes = uno.pulses()[before:]
        first.append(min(p.t_us for p in changes) - t_rx)
        last.append(max(p.t_us for p in changes) - t_rx)
        uno.read_replies(0.02)
    print(  # shown with pytest -s (firmware/README.md quotes it)
        f"\nSET_ALL (39 bytes) -> PCA9685, emulated: first channel latched after "
        f"{statistics.median(first):.0f} us (max {max(first):.0f}), all 16 after "
        f"{statistics.median(last):.0f} us (max {max(last):.0f})"
    )
    assert max(first) < 2000 and max(last) < 5000


def test_pins_variant_drives_twelve_pins(firmware_build: str, tmp_path: Path) -> None:
    board = EmulatedUno(tmp_path, "pins")
    try:
        version = board.wait_ready()
        assert (version.channels, version.output) == (12, proto.OutputKind.PINS)
        ack(
            board.request(proto.set_watchdog(board.next_seq(), proto.WATCHDOG_MAX_MS)),
            "SET_WATCHDOG",
        )
        want = {ch: 1050 + 75 * ch for ch in range(12)}
        ack(board.request(proto.set_all(board.next_seq(), list(want.values()))), "SET_ALL")
        # Software pulses jitter by a few us (interrupt latency); the harness logs changes > 8 us.
        board.wait_for(
            lambda: all(abs(board.widths().get(c, 0) - us) <= 8 for c, us in want.items())
        )
        nack(
            board.request(proto.set_all(board.next_seq(), [1500] * 16)),
            "SET_ALL",
            proto.ErrorCode.BAD_LENGTH,
        )
    finally:
        assert board.close() == 0


def test_missing_board_is_reported(firmware_build: str, tmp_path: Path) -> None:
    board = EmulatedUno(tmp_path, "pca9685", "--no-board")
    try:
        board.wait_ready()
        reply = board.request(proto.set_all(board.next_seq(), [1600] * 16))
        assert isinstance(reply, replies.Ack) and reply.flags & proto.Flags.OUTPUT_FAULT
        status = board.status()
        assert status.flags & proto.Flags.OUTPUT_FAULT
        assert status.output_errors >= 1
        assert board.pulses() == []
    finally:
        assert board.close() == 0


def test_board_connected_late_is_set_up(firmware_build: str, tmp_path: Path) -> None:
    """A PCA9685 that answers only later is woken up with PRE_SCALE 121 and gets every channel."""
    board = EmulatedUno(tmp_path, "pca9685", "--board-after-ms", "400")
    try:
        board.wait_ready()
        ack(
            board.request(proto.set_watchdog(board.next_seq(), proto.WATCHDOG_MAX_MS)),
            "SET_WATCHDOG",
        )
        ack(board.request(proto.set_some(board.next_seq(), {2: 1700})), "SET_SOME")
        # Whether the board appears before or after the command (wall-time race), it ends with
        # every channel written.
        board.wait_for(lambda: len(board.widths()) == 16 and near(board.widths()[2], 1700))
        assert board.widths() == {
            ch: pytest.approx(1700 if ch == 2 else NEUTRAL, abs=2.5) for ch in range(16)
        }
        regs = [(name, int(value, 16)) for _, name, value in board.events("reg")]
        assert ("PRE_SCALE", 121) in regs and regs[-1] == ("MODE1", 0x20)
        assert min(p.t_us for p in board.pulses()) >= 400_000
        status = board.status()
        assert not status.flags & proto.Flags.OUTPUT_FAULT and status.output_errors >= 1
    finally:
        assert board.close() == 0


def test_stack_headroom(firmware_build: str, tmp_path: Path) -> None:
    """The deepest paths (largest frames, STATUS, every NACK) leave RAM to spare."""
    board = EmulatedUno(tmp_path)
    board.wait_ready()
    limits = {ch: proto.Limits(900, 1500, 2100, 5) for ch in range(16)}  # 144-byte payload
    ack(board.request(proto.set_limits(board.next_seq(), limits)), "SET_LIMITS")
    ack(board.request(proto.set_all(board.next_seq(), [1800] * 16)), "SET_ALL")
    board.status()
    nack(
        board.request(proto.encode_frame(board.next_seq(), 0x10, bytes(3))),
        "SET_ALL",
        proto.ErrorCode.BAD_LENGTH,
    )
    board.write(bytes([proto.START, 100]) + bytes(120))  # a false start swallowing bytes
    board.read_replies(0.2)
    board.status()
    assert board.close() == 0
    used, untouched = board.stack_use()
    print(f"\nstack: deepest use {used} bytes; {untouched} bytes of RAM never touched")
    assert untouched >= 256
