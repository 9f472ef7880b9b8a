"""A flooding publisher on one key (run as a process by the flood test; not a test module).

``python flooder.py ROUTER KEY STAGE SECONDS COUNT RATE`` publishes on ``KEY`` at ``RATE``
messages per second (0: as fast as it can) for ``SECONDS`` or ``COUNT`` messages, whichever
comes first, then prints how many it sent. The
messages cycle through what a broken or hostile publisher sends: random bytes, valid msgpack of
the wrong type, messages of the key's type with bad values (NaN, another profile, unknown
servos, a JPEG header declaring 16000x16000 pixels), and now and then one byte over the key's
payload limit (every 65th on a 64 KiB key; every 41,944th on ``input``, whose limit is 40 MiB).
"""

from __future__ import annotations

import json
import os
import sys
import time

import msgspec
import zenoh

from facesynth.runtime import codec, limits
from facesynth.schemas.messages import (
    Features,
    Frame,
    Points,
    PointSet,
    ServiceStats,
    ServoCommands,
)


def bad_messages(stage: str) -> list[bytes]:
    """Messages of the stage's type that every receiver must refuse."""
    huge_jpeg = b"\xff\xd8\xff\xc0\x00\x0b\x08\x3e\x80\x3e\x80\x01\x01\x11\x00" + b"\x00" * 4000
    by_stage: dict[str, list[msgspec.Struct]] = {
        "input": [
            Frame(seq=1, t_capture_ns=1, t_media_ns=1, width=16000, height=16000,
                  encoding="jpeg", data=huge_jpeg),
            Frame(seq=1, t_capture_ns=1, t_media_ns=1, width=64, height=48,
                  encoding="raw", data=b"\x00" * 10),
        ],
        "points": [
            Points(seq=1, t_capture_ns=1, t_media_ns=1, face=True, image_width=640,
                   image_height=480,
                   sets=[PointSet(scheme="ibug68", dims=2, coords=[float("nan")] * 136)]),
        ],
        "features": [
            Features(seq=1, t_capture_ns=1, t_media_ns=1, face=True, distances=[0.5] * 69),
        ],
        "servo_commands": [
            ServoCommands(seq=1, t_capture_ns=1, t_media_ns=1, face=True, profile="paper16",
                          positions={"tail": 1500.0}),
            ServoCommands(seq=1, t_capture_ns=1, t_media_ns=1, face=True, profile="other",
                          positions={"jaw": 2000.0}),
        ],
        "servo_state": [
            ServoCommands(seq=1, t_capture_ns=1, t_media_ns=1, face=True, profile="paper16",
                          positions={"jaw": float("inf")}),
        ],
        "stats": [
            ServiceStats(service="x", instance="y", rig="r", t_ns=1, uptime_s=float("nan"),
                         received=-1, published=0, dropped=0, rejected=0, rate_hz=0.0),
        ],
    }  # fmt: skip
    return [_raw_encode(m) for m in by_stage[stage]]


def _raw_encode(message: msgspec.Struct) -> bytes:
    # codec.encode does not validate: bad values go out as they are.
    return codec.encode(message)


def main() -> None:
    router, key, stage, seconds, count, rate = sys.argv[1:7]
    limit = limits.STATS_LIMIT if stage == "stats" else limits.STAGE_LIMITS[stage]
    cycle = [
        os.urandom(64),
        msgspec.msgpack.encode({"type": "nonsense", "x": [1, 2, 3]}),
        *bad_messages(stage),
    ]
    oversized = b"\x00" * (limit + 1)
    every = max(50, limit // 1000)
    config = zenoh.Config()
    config.insert_json5("mode", '"client"')
    config.insert_json5("connect/endpoints", json.dumps([router]))
    config.insert_json5("scouting/multicast/enabled", "false")
    session = zenoh.open(config)
    publisher = session.declare_publisher(key, congestion_control=zenoh.CongestionControl.DROP)
    print("flooding", flush=True)
    start = time.monotonic()
    end = start + float(seconds)
    period = 1.0 / float(rate) if float(rate) > 0 else 0.0
    sent = 0
    while sent < int(count) and (now := time.monotonic()) < end:
        if period and sent * period > now - start:  # paced: bursts of what is due each ms
            time.sleep(0.001)
            continue
        publisher.put(oversized if sent % every == every - 1 else cycle[sent % len(cycle)])
        sent += 1
    print(json.dumps({"sent": sent, "seconds": float(seconds)}), flush=True)
    publisher.undeclare()
    session.close()


if __name__ == "__main__":
    main()
