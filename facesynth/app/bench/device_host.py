"""A device emulator on a pty, in a process of its own, for ``facesynth bench drivers --emulated``.

The emulators are the test suite's (``tests/control/fake_devices``: the Maestro, the SSC-32,
the Dynamixel and Feetech buses, written from the vendors' documents), so the benchmark needs
a source checkout. Running the device in another process keeps its CPU out of the figure the
benchmark measures, the control side's.

Run as ``python -m facesynth.app.bench.device_host FAKE_DEVICES_PARENT KIND LINK``; it prints
``ready`` once the pty is at LINK, then answers each ``count`` line on stdin with the bytes on
the line since the previous ``count`` and exits (removing the link) when stdin closes. The
answer is ``IN OUT FRAMES MEDIAN MAX``: bytes from the driver and to it, then, on a smart
servo bus, the frames that carried a read-back (a frame runs from one Sync Write to the next,
as the emulator parsed them) and their bytes both ways, median and largest. (On a loaded
machine a stalled sender's poses can arrive together: such a "frame" holds several.)
"""

from __future__ import annotations

import importlib
import statistics
import sys
from pathlib import Path
from typing import Any

#: Emulator kinds -> (module, class, keyword arguments besides the link); ids 1..16 on buses.
KINDS: dict[str, tuple[str, str, dict[str, Any]]] = {
    "maestro": ("fake_devices.maestro", "FakeMaestro", {"channels": 24}),
    "ssc32": ("fake_devices.ssc32", "FakeSSC32", {}),
    "dynamixel2": (
        "fake_devices.dynamixel",
        "FakeDynamixelBus",
        {"ids": list(range(1, 17)), "model": "XL430-W250", "protocol": 2},
    ),
    "dynamixel1": (
        "fake_devices.dynamixel",
        "FakeDynamixelBus",
        {"ids": list(range(1, 17)), "model": "AX-12A", "protocol": 1},
    ),
    "feetech": ("fake_devices.feetech", "FakeFeetechBus", {"ids": list(range(1, 17))}),
}


def make_device(parent: Path, kind: str, link: Path) -> Any:
    """The emulator ``kind`` at ``link`` (not plugged in yet); ``parent`` holds fake_devices."""
    module, name, kwargs = KINDS[kind]
    sys.path.insert(0, str(parent))
    cls = getattr(importlib.import_module(module), name)
    return cls(link, **kwargs)


class FrameTally:
    """Bytes both ways per frame of a smart servo bus (from one Sync Write, 0x83, to the
    next), counted in the emulator's ``handle``."""

    def __init__(self, device: Any) -> None:
        self.frames: list[list[int]] = []  # [bytes in, bytes out] per frame
        self.device = device
        handle = device.handle

        def counted(data: bytes) -> bytes:
            before = len(getattr(device, "packets", ()))
            reply: bytes = handle(data)
            packets = getattr(device, "packets", ())
            if any(len(p) > 1 and p[1] == 0x83 for p in packets[before:]):
                self.frames.append([0, 0])
            if self.frames:
                self.frames[-1][0] += len(data)
                self.frames[-1][1] += len(reply or b"")
            return reply

        device.handle = counted

    def take(self) -> tuple[int, float, int]:
        """Read-back frames since the last call: how many, median and largest bytes (the
        frame still running stays for the next call)."""
        with self.device.lock:
            done, self.frames = self.frames[:-1], self.frames[-1:]
        sizes = [sum(frame) for frame in done if frame[1]]
        if not sizes:
            return 0, 0.0, 0
        return len(sizes), statistics.median(sizes), max(sizes)


def main(argv: list[str]) -> int:
    """Serve one emulated device until stdin closes."""
    parent, kind, link = Path(argv[0]), argv[1], Path(argv[2])
    device = make_device(parent, kind, link)
    tally = FrameTally(device)
    device.plug()
    try:
        print("ready", flush=True)
        for line in sys.stdin:
            if line.strip() == "count":
                got, sent = device.count_bytes(restart=True)
                frames, median, largest = tally.take()
                print(f"{got} {sent} {frames} {median:.1f} {largest}", flush=True)
    finally:
        device.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
