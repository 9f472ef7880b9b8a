"""``facesynth run … --driver maestro|ssc32|arduino --port P``: the whole chain in one process
writes, byte for byte, the poses the pure cores compute, in each board's protocol.

The known input is the bundled OpenFace CSV (every command computed here from the pure cores)
and, for the tracker, the bundled performer video (compared with the same run recorded by the
``record`` driver). The bytes are read back by the fake Maestro and SSC-32 and by the real
firmware on the emulated Uno (the frames its UART received).
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
from facesynth.runtime.profiles import load_profile
from schemas.messages import Frame
from services.control.drivers.arduino import protocol as proto
from services.control.drivers.record import read_record
from services.features.core import FeatureProcessor
from services.points.backends.openface import OpenFaceConfig, OpenFaceReplay
from services.translator.core import Translator

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
    maestro = FakeMaestro(tmp_path / "ttyACM0", channels=24)
    maestro.plug()
    try:
        summary = run(
            "--openface-csv", CSV, "--fast", "--fps", str(FPS),
            "--driver", "maestro", "--port", str(maestro.link), "--maestro-model", "mini24",
        )  # fmt: skip
    finally:
        maestro.close()
    wanted = expected_poses()
    assert summary["commands"] == len(wanted) and moved(wanted) > 50
    contains_in_order(maestro.poses(), wanted, 0.25)
    assert {c[0] for c in maestro.commands} == {0x9F, 0x87, 0x89, 0xA1}  # multiple targets
    assert maestro.error_events == 0
    assert maestro.positions_us()[11] == 1500.0  # neutral at the end


def test_run_drives_an_ssc32(tmp_path: Path) -> None:
    ssc32 = FakeSSC32(tmp_path / "ttyUSB0")
    ssc32.plug()
    try:
        summary = run(
            "--openface-csv", CSV, "--fast", "--fps", str(FPS),
            "--driver", "ssc32", "--port", str(ssc32.link),
        )  # fmt: skip
    finally:
        ssc32.close()
    wanted = expected_poses()
    assert summary["commands"] == len(wanted)
    seen = [{ch: float(us) for ch, us in move.widths.items()} for move in ssc32.moves]
    contains_in_order(seen, wanted, 1)
    assert all(move.speeds[11] == 2500 for move in ssc32.moves) and ssc32.ignored == []
    assert ssc32.widths[11] == 1500


@pytest.mark.firmware
def test_run_drives_the_firmware(uno: UnoRig) -> None:
    summary = run(
        "--openface-csv", CSV, "--fast", "--fps", str(FPS),
        "--driver", "arduino", "--port", str(uno.port),
    )  # fmt: skip
    wanted = expected_poses()
    assert summary["commands"] == len(wanted)
    neutral = proto.COMMANDS["NEUTRAL"].code
    uno.board.wait_for(lambda: uno.commands()[-1].code == neutral)  # the UART has it all
    frames = uno.commands()
    code = proto.COMMANDS["SET_ALL"].code
    seen = [
        {ch: float(int.from_bytes(f.payload[2 * ch : 2 * ch + 2], "little")) for ch in range(16)}
        for f in frames
        if f.code == code
    ]
    contains_in_order(seen, wanted, 1)
    uno.wait_widths({ch: 1500 for ch in range(16)})
    assert len([e for e in uno.board.events("reg") if e[1] == "PRE_SCALE"]) == 1


def test_run_from_the_video_drives_a_maestro_as_recorded(tmp_path: Path) -> None:
    """The tracker on the bundled video: the Maestro gets exactly what ``record`` records."""
    common = ["--video", str(sample_video()), "--max-frames", "72", "--fast"]
    record = tmp_path / "video.jsonl"
    run(*common, "--driver", "record", "--out", str(record))
    maestro = FakeMaestro(tmp_path / "ttyACM0", channels=24)
    maestro.plug()
    try:
        run(
            *common, "--driver", "maestro", "--port", str(maestro.link), "--maestro-model", "mini24"
        )
    finally:
        maestro.close()
    recorded = [
        {CHANNEL[name]: us for name, us in line.servos.items()}
        for line in read_record(record)
        if line.frame is not None
    ]
    assert len(recorded) == 72 and moved(recorded) > 30  # after the 1 s neutral window
    contains_in_order(maestro.poses(), recorded, 0.25)
