"""``facesynth run … --driver maestro|ssc32|arduino --port P``: the whole chain in one process
writes, byte for byte, the poses the control interface sends, in each board's protocol.

The known input is the bundled OpenFace CSV: the translator's commands (recorded with
``--record``) are exactly what the pure cores compute. A board moves a real head, so even in a
``--fast`` run the control interface steps it within the servos' speed limits in real time: the
board gets every pose the control interface reports on ``…/servo_state`` (recorded in the same
run), in order. The bytes are read back by the fake Maestro and SSC-32 and by the real firmware
on the emulated Uno (the frames its UART received).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from fake_devices.maestro import FakeMaestro
from fake_devices.ssc32 import FakeSSC32
from uno_rig import UnoRig

from facesynth.app.data import sample_openface_csv, sample_video
from facesynth.app.recording.reader import Recording
from facesynth.runtime.profiles import load_profile
from facesynth.schemas.messages import Frame
from facesynth.services.control.drivers.arduino import protocol as proto
from facesynth.services.features.core import FeatureProcessor
from facesynth.services.points.backends.openface import OpenFaceConfig, OpenFaceReplay
from facesynth.services.translator.core import Translator

CSV = str(sample_openface_csv())
FPS = 30.0
PROFILE = load_profile("paper16")
CHANNEL = {s.name: s.channel for s in PROFILE.servos}


def expected_poses() -> list[dict[int, float]]:
    """The commands the pure cores give for the CSV at 30 fps, µs by channel."""
    replay = OpenFaceReplay(OpenFaceConfig(csv=CSV))
    processor = FeatureProcessor(neutral_seconds=1.0)
    translator = Translator(PROFILE)
    out = []
    for seq in range(replay.frame_count()):
        frame = Frame(
            seq=seq,
            t_capture_ns=1,
            t_media_ns=round(seq * 1e9 / FPS),
            width=640,
            height=480,
            encoding="none",
        )
        positions = translator.translate(processor.process(replay.process(frame))).positions
        out.append({CHANNEL[name]: us for name, us in positions.items()})
    return out


def recorded(session: Path, stage: str) -> list[tuple[str, dict[int, float]]]:
    """``(move, pose by channel)`` of every message on ``stage`` in the session, in order."""
    with Recording(session) as recording:
        return [
            (message.move, {CHANNEL[name]: us for name, us in message.positions.items()})
            for _, message, _ in recording.messages([f"facesynth/default/{stage}"])
        ]


def sent_poses(session: Path, *, board_neutral: bool = False) -> list[dict[int, float]]:
    """The poses the control interface sent to its driver (its reports left out); with
    ``board_neutral`` also those it sent as the board's own NEUTRAL command (start, and the
    last step of the shutdown) left out."""
    states = recorded(session, "servo_state")
    poses = [(move, pose) for move, pose in states if move != "report"]
    if board_neutral:
        poses = [
            (move, pose)
            for i, (move, pose) in enumerate(poses)
            if move != "start" and not (move == "stop" and i == len(poses) - 1)
        ]
    return [pose for _, pose in poses]


def run(*args: str) -> dict[str, object]:
    result = subprocess.run(
        [sys.executable, "-m", "facesynth", "run", *args, "--listen", "tcp/127.0.0.1:0"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    return json.loads(result.stdout.strip().splitlines()[-1])


def contains_in_order(
    seen: list[dict[int, float]], wanted: list[dict[int, float]], step: float
) -> None:
    """``wanted`` (rounded to ``step``) appears in ``seen`` as one unbroken run."""
    rounded = [{ch: round(us / step) * step for ch, us in pose.items()} for pose in wanted]
    starts = [i for i, pose in enumerate(seen) if pose == rounded[0]]
    assert starts, f"the first command {rounded[0]} never reached the board"
    for start in starts:
        if seen[start : start + len(rounded)] == rounded:
            return
    best = max(starts, key=lambda s: sum(a == b for a, b in zip(seen[s:], rounded, strict=False)))
    pairs = list(zip(seen[best:], rounded, strict=False))
    if all(a == b for a, b in pairs):
        raise AssertionError(f"only {len(pairs)} of {len(rounded)} poses reached the board")
    mismatch = next(i for i, (a, b) in enumerate(pairs) if a != b)
    raise AssertionError(f"pose {mismatch}: board {seen[best + mismatch]} != {rounded[mismatch]}")


def moved(poses: list[dict[int, float]]) -> int:
    return sum(any(abs(us - 1500) > 1 for us in pose.values()) for pose in poses)


def test_run_drives_a_maestro(tmp_path: Path) -> None:
    session = tmp_path / "s.mcap"
    maestro = FakeMaestro(tmp_path / "ttyACM0", channels=24)
    maestro.plug()
    try:
        summary = run(
            "--openface-csv", CSV, "--fast", "--fps", str(FPS), "--record", str(session),
            "--driver", "maestro", "--port", str(maestro.link), "--maestro-model", "mini24",
        )  # fmt: skip
    finally:
        maestro.close()
    wanted = expected_poses()
    assert summary["commands"] == len(wanted) and moved(wanted) > 50
    assert [pose for _, pose in recorded(session, "servo_commands")] == wanted
    contains_in_order(maestro.poses(), sent_poses(session), 0.25)
    assert {c[0] for c in maestro.commands} == {0x9F, 0x87, 0x89, 0xA1}  # multiple targets
    assert maestro.error_events == 0
    assert maestro.positions_us()[11] == 1500.0  # neutral at the end


def test_run_drives_an_ssc32(tmp_path: Path) -> None:
    session = tmp_path / "s.mcap"
    ssc32 = FakeSSC32(tmp_path / "ttyUSB0")
    ssc32.plug()
    try:
        summary = run(
            "--openface-csv", CSV, "--fast", "--fps", str(FPS), "--record", str(session),
            "--driver", "ssc32", "--port", str(ssc32.link),
        )  # fmt: skip
    finally:
        ssc32.close()
    wanted = expected_poses()
    assert summary["commands"] == len(wanted)
    assert [pose for _, pose in recorded(session, "servo_commands")] == wanted
    seen = [{ch: float(us) for ch, us in move.widths.items()} for move in ssc32.moves]
    contains_in_order(seen, sent_poses(session), 1)
    assert all(move.speeds[11] == 2500 for move in ssc32.moves) and ssc32.ignored == []
    assert ssc32.widths[11] == 1500


@pytest.mark.firmware
def test_run_drives_the_firmware(uno: UnoRig, tmp_path: Path) -> None:
    session = tmp_path / "s.mcap"
    summary = run(
        "--openface-csv", CSV, "--fast", "--fps", str(FPS), "--record", str(session),
        "--driver", "arduino", "--port", str(uno.port),
    )  # fmt: skip
    wanted = expected_poses()
    assert summary["commands"] == len(wanted)
    assert [pose for _, pose in recorded(session, "servo_commands")] == wanted
    neutral = proto.COMMANDS["NEUTRAL"].code
    uno.board.wait_for(lambda: uno.commands()[-1].code == neutral)  # the UART has it all
    frames = uno.commands()
    code = proto.COMMANDS["SET_ALL"].code
    seen = [
        {ch: float(int.from_bytes(f.payload[2 * ch : 2 * ch + 2], "little")) for ch in range(16)}
        for f in frames
        if f.code == code
    ]
    contains_in_order(seen, sent_poses(session, board_neutral=True), 1)
    uno.wait_widths({ch: 1500 for ch in range(16)})
    assert len([e for e in uno.board.events("reg") if e[1] == "PRE_SCALE"]) == 1


def test_run_from_the_video_drives_a_maestro_with_every_pose_sent(tmp_path: Path) -> None:
    """The tracker on the bundled video: the Maestro gets exactly what the control interface
    reports sending, and the face moves."""
    session = tmp_path / "s.mcap"
    maestro = FakeMaestro(tmp_path / "ttyACM0", channels=24)
    maestro.plug()
    try:
        run(
            "--video", str(sample_video()), "--max-frames", "72", "--fast",
            "--record", str(session),
            "--driver", "maestro", "--port", str(maestro.link), "--maestro-model", "mini24",
        )  # fmt: skip
    finally:
        maestro.close()
    commanded = [pose for move, pose in recorded(session, "servo_state") if move == "command"]
    assert len(commanded) == 72 and moved(commanded) > 30  # after the 1 s neutral window
    contains_in_order(maestro.poses(), sent_poses(session), 0.25)
