"""A short-lived publisher as any Zenoh program writes one: default settings, so its payloads of
3 KiB or more go through its shared memory pool wherever the link allows it (run as a process by
the router memory test; not a test module).

``python short_publisher.py ROUTER KEY COUNT SIZE`` publishes COUNT payloads of SIZE bytes, then
closes its session and exits; prints ``sent COUNT``.
"""

from __future__ import annotations

import json
import sys
import time

import zenoh


def main() -> None:
    router, key, count, size = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
    config = zenoh.Config()
    config.insert_json5("mode", '"client"')
    config.insert_json5("connect/endpoints", json.dumps([router]))
    config.insert_json5("scouting/multicast/enabled", "false")
    session = zenoh.open(config)
    publisher = session.declare_publisher(key, congestion_control=zenoh.CongestionControl.BLOCK)
    payload = bytes(size)
    for _ in range(count):
        publisher.put(payload)
    time.sleep(0.3)
    publisher.undeclare()
    session.close()
    print(f"sent {count}", flush=True)


if __name__ == "__main__":
    main()
