"""A replayed recording is no live capture: the capture host of its frames is cleared (so no
stage ages them from capture at another speed), ``--restamp`` names this host, and payloads that
name none (older recordings, ``--fast`` runs) are published byte for byte."""

from __future__ import annotations

import asyncio
from pathlib import Path

import msgspec

from facesynth.app.recording.layout import Layout
from facesynth.app.recording.reader import Recording
from facesynth.app.recording.replay import Replayer, ReplayOptions
from facesynth.app.recording.writer import SessionWriter
from facesynth.runtime import codec, keys
from facesynth.runtime.bus.memory import MemoryNetwork
from facesynth.runtime.clock_host import clock_host
from facesynth.runtime.service import ServiceContext
from facesynth.schemas.messages import Frame

RIG = "default"
KEY = keys.stage_key(RIG, "input")
T0 = 1_700_000_000_000_000_000


def frame(seq: int, capture_host: str) -> Frame:
    return Frame(
        seq=seq,
        t_capture_ns=T0 + seq * 33_333_333,
        t_media_ns=seq * 33_333_333,
        width=640,
        height=480,
        encoding="none",
        capture_host=capture_host,
    )


def without_capture_host(message: Frame) -> bytes:
    """``message`` as a sender from before capture hosts encoded it (no such field at all)."""
    fields = msgspec.msgpack.decode(codec.encode(message))
    del fields["capture_host"]
    return msgspec.msgpack.encode(fields)


def write(path: Path, payloads: list[bytes]) -> None:
    layout = Layout()
    writer = SessionWriter(path, metadata={"rig": RIG}, fsync=False)
    for seq, payload in enumerate(payloads):
        for entry in layout.entries(KEY, payload, 1_000_000_000 + seq * 1_000_000, seq):
            writer.write(entry)
    writer.close()


async def replay(path: Path, restamp: bool) -> list[bytes]:
    network = MemoryNetwork()
    probe = network.bus().subscribe_queued(KEY, 100)
    options = ReplayOptions(stage="input", speed=1000.0, restamp=restamp)
    with Recording(path) as recording:
        replayer = Replayer(recording, options)
        await replayer.serve(ServiceContext(network.bus(), RIG, "replay"))
    await asyncio.sleep(0)
    out = []
    while (sample := probe.receive_nowait()) is not None:
        out.append(sample.payload)
    return out


async def test_a_replay_clears_the_capture_host_and_keeps_the_recorded_stamps(
    tmp_path: Path,
) -> None:
    session = tmp_path / "session.mcap"
    recorded = [codec.encode(frame(0, "camera")), codec.encode(frame(1, "camera"))]
    write(session, recorded)
    published = [codec.decode(p, Frame) for p in await replay(session, restamp=False)]
    assert [(f.seq, f.capture_host) for f in published] == [(0, ""), (1, "")]
    assert [f.t_capture_ns for f in published] == [T0, T0 + 33_333_333]


async def test_payloads_naming_no_capture_host_are_replayed_byte_for_byte(tmp_path: Path) -> None:
    session = tmp_path / "session.mcap"
    recorded = [codec.encode(frame(0, "")), without_capture_host(frame(1, "camera"))]
    write(session, recorded)
    assert await replay(session, restamp=False) == recorded


async def test_a_restamped_replay_is_a_live_capture_of_this_host(tmp_path: Path) -> None:
    session = tmp_path / "session.mcap"
    write(session, [codec.encode(frame(0, "camera")), without_capture_host(frame(1, ""))])
    published = [codec.decode(p, Frame) for p in await replay(session, restamp=True)]
    assert {f.capture_host for f in published} == {clock_host()}
    assert all(f.t_capture_ns > T0 for f in published)  # stamped now, not at the recording
