"""Sends a burst of big messages on one key (run as a process by the big-message test).

``python big_sender.py ROUTER KEY KIND COUNT INTERVAL_S``; KIND is ``commands`` (a ServoCommands
with a million-entry positions map, about 18 MB), ``jpeg`` (a 4 MB Frame whose JPEG header
declares 16000x16000 pixels) or ``bytes`` (18 MB of zeros). Prints ``sent N`` at the end.
"""

from __future__ import annotations

import json
import sys
import time

import zenoh

from facesynth.runtime import codec
from facesynth.schemas.messages import Frame, ServoCommands


def payload(kind: str) -> bytes:
    if kind == "commands":
        positions = {f"servo{i:07d}": 1500.0 for i in range(1_000_000)}
        return codec.encode(
            ServoCommands(seq=1, t_capture_ns=1, t_media_ns=1, face=True, profile="paper16",
                          positions=positions)
        )  # fmt: skip
    if kind == "jpeg":
        header = b"\xff\xd8\xff\xc0\x00\x0b\x08\x3e\x80\x3e\x80\x01\x01\x11\x00"
        data = header + b"\x00" * 4_000_000
        return codec.encode(
            Frame(seq=1, t_capture_ns=1, t_media_ns=1, width=16000, height=16000,
                  encoding="jpeg", data=data)
        )  # fmt: skip
    return bytes(18_000_000)


def main() -> None:
    router, key, kind, count, interval = sys.argv[1:6]
    data = payload(kind)
    config = zenoh.Config()
    config.insert_json5("mode", '"client"')
    config.insert_json5("connect/endpoints", json.dumps([router]))
    config.insert_json5("scouting/multicast/enabled", "false")
    session = zenoh.open(config)
    publisher = session.declare_publisher(key, congestion_control=zenoh.CongestionControl.BLOCK)
    print(f"ready {len(data)}", flush=True)
    for _ in range(int(count)):
        publisher.put(data)
        time.sleep(float(interval))
    print(f"sent {count}", flush=True)
    time.sleep(0.5)
    publisher.undeclare()
    session.close()


if __name__ == "__main__":
    main()
