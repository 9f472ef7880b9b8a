"""Record a live chain, replay it from each stage: the same commands, and the same bytes."""

from __future__ import annotations

import time
from pathlib import Path

from session_chain import live_run, replay_run

from facesynth.app.data import sample_video
from facesynth.app.recording.convert import export_jsonl, landmarks_to_mcap
from facesynth.app.recording.reader import Recording
from facesynth.runtime import codec, keys
from facesynth.schemas.messages import Frame
from facesynth.services.control.drivers.record import read_record
from facesynth.services.points.backends.openface import OpenFaceConfig, OpenFaceReplay
from facesynth.services.sensor.sources.ticks import TicksConfig, TickSource
from facesynth.services.sensor.sources.video import VideoConfig, VideoSource

OPENFACE = Path(__file__).parents[3] / "facesynth" / "app" / "data" / "OpenFace_Test.csv"


async def test_replaying_each_stage_gives_the_live_commands(tmp_path: Path, rig: str) -> None:
    session = tmp_path / "session.mcap"
    backend = OpenFaceReplay(OpenFaceConfig(csv=str(OPENFACE)))
    live = await live_run(
        tmp_path,
        rig,
        TickSource(TicksConfig(count=backend.frame_count())),
        backend,
        session=session,
    )
    assert len(live) == 100 and sum(1 for _, servos in live if servos) == 100
    with Recording(session) as recording:
        for stage in keys.STAGES[:-1]:
            assert recording.count(keys.stage_key(rig, stage)) == 100, stage
        states = [m for _, m, _ in recording.messages([keys.stage_key(rig, "servo_state")])]
        assert len([m for m in states if m.move == "command"]) == 100  # and C's own moves
        assert any("/stats/" in key for key in recording.bus_keys())
    for stage in ("input", "points", "features", "servo_commands"):
        fresh = OpenFaceReplay(OpenFaceConfig(csv=str(OPENFACE))) if stage == "input" else None
        replayed, replayer = await replay_run(tmp_path, rig + "b", session, stage, backend=fresh)
        assert replayer.published == 100 and replayer.stalls == 0, stage
        assert replayed == live, f"replay from {stage} differs from the live run"


async def test_the_recorded_state_exports_as_the_drivers_lines(tmp_path: Path, rig: str) -> None:
    session = tmp_path / "session.mcap"
    backend = OpenFaceReplay(OpenFaceConfig(csv=str(OPENFACE)))
    live = await live_run(
        tmp_path,
        rig,
        TickSource(TicksConfig(count=backend.frame_count())),
        backend,
        session=session,
    )
    with Recording(session) as recording:
        assert export_jsonl(recording, tmp_path / "state.jsonl") == 100
    exported = read_record(tmp_path / "state.jsonl")
    assert [(line.frame, line.servos) for line in exported] == live
    assert [line.seq for line in exported] == list(range(100))


async def test_replaying_tracked_frames_gives_the_live_commands(tmp_path: Path, rig: str) -> None:
    from facesynth.services.points.backends.tracker import TrackerBackend

    session = tmp_path / "video.mcap"
    live = await live_run(
        tmp_path,
        rig,
        VideoSource(VideoConfig(path=str(sample_video()))),
        TrackerBackend(),
        session=session,
        max_frames=30,
    )
    assert len(live) == 30
    with Recording(session) as recording:
        frames = [
            codec.decode(p.payload, Frame)
            for p in recording.payloads(recording.bus_keys())
            if p.key.endswith("/input")
        ]
    assert len(frames) == 30 and all(f.encoding == "jpeg" and f.data for f in frames)
    replayed, _ = await replay_run(tmp_path, rig + "b", session, "input", backend=TrackerBackend())
    assert replayed == live


async def test_a_converted_openface_file_replays_like_the_csv(tmp_path: Path, rig: str) -> None:
    live = await live_run(
        tmp_path,
        rig,
        TickSource(TicksConfig(count=100)),
        OpenFaceReplay(OpenFaceConfig(csv=str(OPENFACE))),
    )
    session = tmp_path / "openface.mcap"
    assert landmarks_to_mcap(OPENFACE, session, rig=rig, fps=30.0) == 100
    fast, replayer = await replay_run(tmp_path, rig, session, "points")
    assert fast == live and replayer.published == 100
    started = time.monotonic()
    timed, replayer = await replay_run(tmp_path, rig, session, "points", fast=False, speed=4.0)
    elapsed = time.monotonic() - started
    # 100 frames at 30 fps is 3.3 s of media; at speed 4 the replay keeps that pace (about 0.8 s).
    assert 0.75 < elapsed < 3.3, elapsed
    assert replayer.published == 100
    # In real time a stage that stalls (a loaded machine) drops frames as it would live; every
    # command that does come is the live one for its frame.
    by_frame = dict(live)
    differ = [
        (frame, servos, by_frame[frame]) for frame, servos in timed if servos != by_frame[frame]
    ]
    assert not differ, differ[:2]
    assert len(timed) >= 80, len(timed)
