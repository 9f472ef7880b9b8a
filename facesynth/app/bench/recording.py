"""``facesynth bench recording``: a long session through the real recording writer.

A synthetic session of ``minutes`` at ``fps`` (per frame: a JPEG frame, points with the 68-point
view, the 468-point mesh and the iris, features, servo commands and applied positions; stats of
five services every second) goes through the same :class:`Layout` and :class:`SessionWriter` as
``facesynth record`` (chunks cut every second of session time, fsynced), as fast as the machine
allows. Side by side, what one would write by hand instead: the msgpack payloads appended to a
file with a length prefix (no schema, index, compression or viewer).

Memory: a second pass of the facesynth writer under ``tracemalloc`` reports the Python heap it
holds after each minute and its peak, with the process RSS; bounded means the figures after
minute 1 and after the last minute stay the same, not growing with the session's length.
"""

from __future__ import annotations

import os
import struct
import tempfile
import time
import tracemalloc
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from facesynth.app.recording.layout import Layout
from facesynth.app.recording.writer import SessionWriter
from facesynth.app.stages.registry import STAGES
from facesynth.runtime import codec
from facesynth.runtime.feature_names import NAMES
from facesynth.runtime.stats import memory_mb
from facesynth.schemas.messages import (
    Features,
    Frame,
    Points,
    PointSet,
    ServiceStats,
    ServoCommands,
)

T0 = 1_700_000_000_000_000_000
#: The services whose stats the session holds: every stage of the chain.
SERVICES = STAGES.names()
SERVOS = tuple(f"servo_{i}" for i in range(16))


def sample_jpegs(size: tuple[int, int], count: int = 60) -> list[bytes]:
    """JPEGs of the bundled video's first ``count`` frames at ``size``, cycled by the session
    (so a chunk holds different pictures, as in a real recording, not one repeated)."""
    import cv2

    from facesynth.app.data import sample_video

    capture = cv2.VideoCapture(str(sample_video()))
    out: list[bytes] = []
    try:
        while len(out) < count:
            ok, image = capture.read()
            if not ok:
                break
            ok, data = cv2.imencode(".jpg", cv2.resize(image, size), [cv2.IMWRITE_JPEG_QUALITY, 90])
            assert ok
            out.append(data.tobytes())
    finally:
        capture.release()
    if not out:
        raise RuntimeError("cannot read the bundled sample video")
    return out


def synthetic_session(
    minutes: float, fps: float, jpegs: list[bytes], size: tuple[int, int], *, mesh: bool = True
) -> Iterator[tuple[str, bytes, int]]:
    """``(key, payload, t_ns)`` of a session, in time order (``mesh``: points carry the mesh)."""
    rng = np.random.default_rng(7)
    mesh_coords = rng.uniform(100, 400, 468 * 3)
    ibug = rng.uniform(100, 400, 136)
    iris = rng.uniform(100, 400, 20)
    frames = round(minutes * 60 * fps)
    for seq in range(frames):
        t = T0 + round(seq * 1e9 / fps)
        media = t - T0
        jitter = rng.normal(0, 0.3, 3)
        sets = [
            PointSet(scheme="ibug68", dims=2, coords=(ibug + jitter[0]).tolist()),
            PointSet(scheme="iris10", dims=2, coords=(iris + jitter[2]).tolist()),
        ]
        if mesh:
            sets.append(
                PointSet(scheme="mesh468", dims=3, coords=(mesh_coords + jitter[1]).tolist())
            )
        distances = rng.uniform(0.2, 1.5, 68).tolist()
        commands = ServoCommands(
            seq=seq,
            t_capture_ns=t,
            t_media_ns=media,
            face=True,
            profile="paper16",
            positions={
                name: 1500.0 + 200.0 * float(np.sin(seq / 30 + i)) for i, name in enumerate(SERVOS)
            },
        )
        messages: list[tuple[str, Any]] = [
            (
                "input",
                Frame(
                    seq=seq,
                    t_capture_ns=t,
                    t_media_ns=media,
                    width=size[0],
                    height=size[1],
                    encoding="jpeg",
                    data=jpegs[seq % len(jpegs)],
                    fps=fps,
                ),
            ),
            (
                "points",
                Points(
                    seq=seq,
                    t_capture_ns=t,
                    t_media_ns=media,
                    face=True,
                    confidence=0.98,
                    image_width=size[0],
                    image_height=size[1],
                    sets=sets,
                    source="tracker",
                ),
            ),
            (
                "features",
                Features(
                    seq=seq,
                    t_capture_ns=t,
                    t_media_ns=media,
                    face=True,
                    neutral_ready=True,
                    distances=distances,
                    deltas=distances,
                    named={n: 0.1 for n in NAMES},
                    raw={n: 0.01 for n in NAMES},
                    displacements=rng.normal(0, 0.01, 136).tolist(),
                ),
            ),
            ("servo_commands", commands),
            ("servo_state", commands),  # the controller applied them as they came
        ]
        for stage, message in messages:
            yield f"facesynth/default/{stage}", codec.encode(message), t + 1_000_000
        if seq % round(fps) == 0:
            for service in SERVICES:
                stats = ServiceStats(
                    service=service,
                    instance="bench-1",
                    rig="default",
                    t_ns=t,
                    uptime_s=seq / fps,
                    received=seq,
                    published=seq,
                    dropped=0,
                    rejected=0,
                    rate_hz=fps,
                    latency_p50_ms=2.0,
                    latency_p99_ms=4.0,
                )
                yield f"facesynth/default/stats/{service}/bench-1", codec.encode(stats), t


class _SessionClock:
    """The chunk timer follows session time, as it follows wall time when recording live."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def record_session(
    path: Path,
    minutes: float,
    fps: float,
    jpegs: list[bytes],
    size: tuple[int, int],
    *,
    trace: bool = False,
    mesh: bool = True,
) -> dict[str, Any]:
    """Write a synthetic session with the recording writer; figures per minute when tracing."""
    clock = _SessionClock()
    layout = Layout()
    if trace:
        tracemalloc.start()
    started = time.perf_counter()
    writer = SessionWriter(
        path, metadata={"rig": "default", "bench": "1"}, clock=clock, overwrite=True
    )
    per_minute: list[dict[str, float]] = []

    def minute_ended() -> None:
        traced = tracemalloc.get_traced_memory()[0] / 2**20 if trace else 0.0
        per_minute.append(
            {"minute": len(per_minute) + 1, "traced_mb": traced, "rss_mb": memory_mb()[0]}
        )

    messages = 0
    next_minute = 60.0
    for key, payload, t in synthetic_session(minutes, fps, jpegs, size, mesh=mesh):
        clock.now = (t - T0) / 1e9
        for entry in layout.entries(key, payload, t, messages):
            writer.write(entry)
        writer.tick()
        messages += 1
        if clock.now >= next_minute:
            next_minute += 60.0
            minute_ended()
    writer.close()
    seconds = time.perf_counter() - started
    if clock.now + 1.0 >= next_minute:  # the last minute ends with the last frame
        minute_ended()
    peak = tracemalloc.get_traced_memory()[1] / 2**20 if trace else 0.0
    if trace:
        tracemalloc.stop()
    return {
        "messages": messages,
        "mb": path.stat().st_size / 2**20,
        "seconds": seconds,
        "chunks": writer.chunks,
        "peak_traced_mb": peak,
        "per_minute": per_minute,
    }


def dump_session(
    path: Path, minutes: float, fps: float, jpegs: list[bytes], size: tuple[int, int]
) -> dict[str, Any]:
    """The hand-made alternative: length-prefixed msgpack payloads, flushed every second."""
    started = time.perf_counter()
    messages = 0
    last_flush = 0
    with open(path, "wb") as handle:
        for key, payload, t in synthetic_session(minutes, fps, jpegs, size):
            name = key.encode()
            handle.write(struct.pack("<HQI", len(name), t, len(payload)) + name + payload)
            messages += 1
            if t - last_flush >= 1_000_000_000:
                handle.flush()
                os.fsync(handle.fileno())
                last_flush = t
    return {
        "messages": messages,
        "mb": path.stat().st_size / 2**20,
        "seconds": time.perf_counter() - started,
    }


def bench_recording(
    minutes: float = 10.0, fps: float = 30.0, size: tuple[int, int] = (640, 360)
) -> dict[str, Any]:
    """Time both writers, then trace the recording writer's memory over the whole session."""
    jpegs = sample_jpegs(size)
    with tempfile.TemporaryDirectory(prefix="facesynth-bench-") as folder:
        base = Path(folder)
        mcap = record_session(base / "session.mcap", minutes, fps, jpegs, size)
        (base / "session.mcap").unlink()
        dump = dump_session(base / "session.msgpack", minutes, fps, jpegs, size)
        (base / "session.msgpack").unlink()
        traced = record_session(base / "traced.mcap", minutes, fps, jpegs, size, trace=True)
    return {
        "minutes": minutes,
        "fps": fps,
        "size": size,
        "jpeg_kb": sum(map(len, jpegs)) / len(jpegs) / 1024,
        "mcap": mcap,
        "dump": dump,
        "traced": traced,
    }


def format_recording_bench(result: dict[str, Any]) -> str:
    """A side-by-side table of a :func:`bench_recording` result."""
    session_s = result["minutes"] * 60
    w, h = result["size"]
    lines = [
        f"session: {result['minutes']:g} min at {result['fps']:g} fps, JPEG {w}x{h} "
        f"(mean {result['jpeg_kb']:.0f} KB, the video's first 60 frames cycled), points with mesh, "
        "features, commands, state, stats",
        f"{'writer':<44} {'messages':>9} {'MB':>8} {'s':>7} {'msg/s':>8} {'x real time':>12}",
    ]
    for name, figures in (
        ("facesynth record (MCAP, zstd, views, fsync)", result["mcap"]),
        ("msgpack dump (length-prefixed, fsync/s)", result["dump"]),
    ):
        lines.append(
            f"{name:<44} {figures['messages']:>9} {figures['mb']:>8.1f} "
            f"{figures['seconds']:>7.1f} {figures['messages'] / figures['seconds']:>8.0f} "
            f"{session_s / figures['seconds']:>12.1f}"
        )
    traced = result["traced"]
    minutes = traced["per_minute"]
    if minutes:
        first, last = minutes[0], minutes[-1]
        lines.append(
            f"memory (recording writer, tracemalloc): Python heap after minute {first['minute']} "
            f"{first['traced_mb']:.2f} MB, after minute {last['minute']} "
            f"{last['traced_mb']:.2f} MB, "
            f"peak {traced['peak_traced_mb']:.2f} MB; process RSS {first['rss_mb']:.0f} -> "
            f"{last['rss_mb']:.0f} MB; {traced['chunks']} chunks"
        )
    return "\n".join(lines)
