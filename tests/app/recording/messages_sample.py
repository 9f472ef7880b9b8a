"""One valid message of every kind on a rig's keys, for layout and file tests."""

from __future__ import annotations

import cv2
import numpy as np

from facesynth.runtime import codec
from facesynth.schemas.messages import (
    Features,
    Frame,
    Points,
    PointSet,
    ServiceStats,
    ServoCommands,
)

IMAGE = np.full((48, 64, 3), (10, 120, 240), np.uint8)


def jpeg() -> bytes:
    ok, data = cv2.imencode(".jpg", IMAGE)
    assert ok
    return data.tobytes()


def messages(
    seq: int, rig: str = "default", t0: int = 1_700_000_000_000_000_000
) -> list[tuple[str, bytes]]:
    """(key, payload) of one frame's worth of messages, plus one stats message."""
    t = t0 + seq * 33_333_333
    media = seq * 33_333_333
    ibug = [float(i % 17) * 3.25 + seq * 0.1 for i in range(136)]
    mesh = [float(i % 29) * 1.5 - 0.0 for i in range(468 * 3)]
    iris = [20.0 + i * 0.5 for i in range(20)]
    items = [
        (
            "input",
            Frame(
                seq=seq,
                t_capture_ns=t,
                t_media_ns=media,
                width=64,
                height=48,
                encoding="jpeg",
                data=jpeg(),
                source="cam",
                fps=30.0,
            ),
        ),
        (
            "input",
            Frame(
                seq=seq,
                t_capture_ns=t,
                t_media_ns=media,
                width=4,
                height=2,
                encoding="raw",
                data=bytes(range(24)),
                fps=30.0,
            ),
        ),
        (
            "input",
            Frame(
                seq=seq, t_capture_ns=t, t_media_ns=media, width=640, height=480, encoding="none"
            ),
        ),
        (
            "points",
            Points(
                seq=seq,
                t_capture_ns=t,
                t_media_ns=media,
                face=True,
                confidence=0.87,
                image_width=64,
                image_height=48,
                sets=[
                    PointSet(scheme="ibug68", dims=2, coords=ibug),
                    PointSet(scheme="mesh468", dims=3, coords=mesh),
                    PointSet(scheme="iris10", dims=2, coords=iris),
                ],
                source="tracker",
            ),
        ),
        (
            "points",
            Points(
                seq=seq,
                t_capture_ns=t,
                t_media_ns=media,
                face=False,
                image_width=64,
                image_height=48,
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
                distances=[0.1 * i for i in range(68)],
                deltas=[-0.0, 1e-300, 999999.9999999999, 0.1 + 0.2] + [0.0] * 64,
                named={"jaw_open": 0.25, "smile_left": -1.0 / 3.0},
                raw={"jaw_open": 0.01},
            ),
        ),
        (
            "servo_commands",
            ServoCommands(
                seq=seq,
                t_capture_ns=t,
                t_media_ns=media,
                face=True,
                profile="paper16",
                positions={"jaw": 1500.125, "right_eyebrow": 1234.5},
            ),
        ),
        (
            "servo_state",
            ServoCommands(
                seq=seq,
                t_capture_ns=t,
                t_media_ns=media,
                face=True,
                profile="paper16",
                positions={"jaw": 1500.125, "right_eyebrow": 1234.5},
            ),
        ),
    ]
    out = [(f"facesynth/{rig}/{stage}", codec.encode(message)) for stage, message in items]
    stats = ServiceStats(
        service="features",
        instance="host-1",
        rig=rig,
        t_ns=t,
        uptime_s=1.5,
        received=seq,
        published=seq,
        dropped=0,
        rejected=0,
        rate_hz=30.0,
        latency_p50_ms=1.25,
        latency_p99_ms=None,
    )
    out.append((f"facesynth/{rig}/stats/features/host-1", codec.encode(stats)))
    return out
