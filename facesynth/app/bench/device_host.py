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
:class:`DeviceHost` starts such a process and asks it, for ``bench drivers --emulated`` and
``bench run`` alike.
"""

from __future__ import annotations

import contextlib
import importlib
import statistics
import subprocess
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


#: An emulator's counts: bytes in, out; read-back frames, their median and largest bytes.
Counts = tuple[int, int, int, float, int]


class EmulatorStartError(RuntimeError):
    """A device_host process that did not say it was ready."""


class DeviceHost:
    """A device_host process serving emulator ``kind`` at ``link`` (``parent`` holds
    fake_devices), ready once built: its byte counts (:meth:`close` it)."""

    def __init__(self, parent: Path, kind: str, link: Path) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "facesynth.app.bench.device_host", str(parent), kind, str(link)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        assert self.proc.stdout is not None and self.proc.stdin is not None
        line = self.proc.stdout.readline().strip()
        if line != "ready":
            self.close()
            raise EmulatorStartError(f"the {kind} emulator did not start ({line!r})")

    def count(self) -> Counts:
        """The counts since the previous call (see the module)."""
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.proc.stdin.write("count\n")
        self.proc.stdin.flush()
        got, sent, frames, median, largest = self.proc.stdout.readline().split()
        return int(got), int(sent), int(frames), float(median), int(largest)

    def close(self) -> None:
        """Close its stdin, so it exits; killed if it has not within 5 s."""
        with contextlib.suppress(OSError):
            assert self.proc.stdin is not None
            self.proc.stdin.close()
        try:
            self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()


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
