"""``facesynth run --video … --driver dynamixel|feetech --port P``: the whole chain from the
performer video drives an emulated servo bus; every Sync Write on the bus is a pose the
control interface reports sending (servo_state), in order, converted to native units, and
the face is neutral at the end (with the torque still on: ``--bus-at-exit hold``)."""

from __future__ import annotations

import math
from pathlib import Path

from fake_devices.dynamixel import FakeDynamixelBus
from fake_devices.feetech import FakeFeetechBus
from test_run_with_boards import moved, recorded, run

from facesynth.app.data import sample_video
from facesynth.app.recording.reader import Recording
from facesynth.runtime.profiles import load_profile
from facesynth.services.control.drivers.bus_servo.native import Model, native_servo

PROFILE = load_profile("paper16")
X = Model("XL430-W250", 1060, 4096, 360.0)
#: A pose that stays the newest this long reaches the bus (a read-back takes a few ms; an
#: answer lost to a loaded machine, one timeout of 34 ms).
HELD_S = 0.08


def bus_poses(packets: list[bytes], size: int, order: str) -> list[dict[int, int]]:
    """The goal positions of every Sync Write on the bus (id -> native), in order."""
    head = 4 if size == 4 else 2
    poses = []
    for packet in packets:
        if packet[0] != 0xFE or packet[1] != 0x83:
            continue
        body = packet[2 + head :]
        poses.append(
            {
                body[at]: int.from_bytes(body[at + 1 : at + 1 + size], order)  # type: ignore[arg-type]
                for at in range(0, len(body), size + 1)
            }
        )
    return poses


def sent_with_times(session: Path) -> list[tuple[int, dict[str, float]]]:
    """(sent_ns, positions) of every pose the control interface sent its driver."""
    with Recording(session) as recording:
        return [
            (message.sent_ns, dict(message.positions))
            for _, message, _ in recording.messages(["facesynth/default/servo_state"])
            if message.move != "report"
        ]


def check(seen: list[dict[int, int]], session: Path) -> None:
    servos = {s.name: native_servo(s, X) for s in PROFILE.servos}
    ids = {s.name: s.channel + 1 for s in PROFILE.servos}
    sent: list[tuple[int, dict[int, int]]] = []
    for sent_ns, positions in sent_with_times(session):
        pose = {ids[name]: servos[name].native(us) for name, us in positions.items()}
        if not sent or sent[-1][1] != pose:  # a pose repeated is one pose
            sent.append((sent_ns, pose))
    commanded = [pose for move, pose in recorded(session, "servo_state") if move == "command"]
    assert len(commanded) == 72 and moved(commanded) > 30
    neutral = {i: servos[name].neutral for name, i in ids.items()}
    assert seen[0] == neutral  # written at connect: the pose the driver holds until told
    distinct = [pose for i, pose in enumerate(seen) if not i or pose != seen[i - 1]]
    # Every pose on the bus was sent, in order. The bus thread writes the newest pose: one
    # that a newer one replaced within a few ms (C sends some in pairs) may never go out,
    # but every pose that stayed the newest for HELD_S did.
    at = 0
    for pose in distinct:
        while at < len(sent) and sent[at][1] != pose:
            held = (sent[at + 1][0] - sent[at][0]) / 1e9 if at + 1 < len(sent) else math.inf
            assert held < HELD_S, f"pose {at}, the newest for {held:.3f} s, never went out"
            at += 1
        assert at < len(sent), f"a pose on the bus that was never sent: {pose}"
        at += 1
    assert at == len(sent), "the last poses never went out"
    assert sum(pose != neutral for pose in distinct) > 20 and seen[-1] == neutral


def test_run_from_the_video_drives_a_dynamixel_bus(tmp_path: Path) -> None:
    session = tmp_path / "s.mcap"
    bus = FakeDynamixelBus(tmp_path / "ttyDXL", list(range(1, 17)))
    bus.plug()
    try:
        run(
            "--video", str(sample_video()), "--max-frames", "72", "--fast",
            "--record", str(session), "--driver", "dynamixel", "--port", str(bus.link),
            "--baud", "1000000",
        )  # fmt: skip
        with bus.lock:
            seen = bus_poses(bus.packets, 4, "little")
            torque = [s.torque_on for s in bus.servos.values()]
    finally:
        bus.close()
    check(seen, session)
    assert all(torque)


def test_run_from_the_video_drives_a_feetech_bus(tmp_path: Path) -> None:
    session = tmp_path / "s.mcap"
    bus = FakeFeetechBus(tmp_path / "ttySTS", list(range(1, 17)))
    bus.plug()
    try:
        run(
            "--video", str(sample_video()), "--max-frames", "72", "--fast",
            "--record", str(session), "--driver", "feetech", "--port", str(bus.link),
        )  # fmt: skip
        with bus.lock:
            seen = bus_poses(bus.packets, 2, "little")
    finally:
        bus.close()
    check(seen, session)
