"""Build the Uno servo firmware and run it on the simavr harness, for the firmware tests.

The harness (``firmware/emulator``, GPL-3, a test tool) logs what the servos see, stamped with
emulated time; :class:`EmulatedUno` starts it, talks to the firmware over its pty with pyserial
and reads that log back.
"""

from __future__ import annotations

import fcntl
import subprocess
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import host_requirements
import serial

from facesynth.services.control.drivers.arduino import protocol as proto
from facesynth.services.control.drivers.arduino import replies

REPO = Path(__file__).resolve().parents[2]
FIRMWARE = REPO / "firmware"
BUILD = FIRMWARE / "build"
ELF = {
    "pca9685": BUILD / "pca9685" / "facesynth_servo.elf",
    "pins": BUILD / "pins" / "facesynth_servo.elf",
}
HARNESS = BUILD / "emulator" / "fs_emulator"


def missing_packages() -> list[str]:
    """Debian packages whose files the firmware tests need but cannot find."""
    return host_requirements.missing_packages(host_requirements.FIRMWARE_NEEDS)


def build_firmware() -> str:
    """``make -C firmware build emulator``; returns its output, raises with it on failure.

    Test processes running side by side (pytest-xdist's workers) take turns, through a lock
    file beside the build: two makes writing one ELF at once would leave a torn file."""
    BUILD.mkdir(parents=True, exist_ok=True)
    with open(BUILD / ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        result = subprocess.run(
            ["make", "-C", str(FIRMWARE), "-j2", "build", "emulator"],
            capture_output=True,
            text=True,
            check=False,
        )
    if result.returncode != 0:
        raise RuntimeError(f"firmware build failed:\n{result.stdout}\n{result.stderr}")
    return result.stdout


def static_ram_end(elf: Path) -> int:
    """The firmware's ``_end`` symbol (end of .data + .bss), from avr-nm."""
    out = subprocess.run(["avr-nm", str(elf)], capture_output=True, text=True, check=True).stdout
    for line in out.splitlines():
        parts = line.split()  # "address type name"; undefined symbols have no address
        if len(parts) == 3 and parts[2] == "_end":
            return int(parts[0], 16)
    raise RuntimeError(f"no _end symbol in {elf}")


@dataclass(frozen=True)
class Pulse:
    """A channel's pulse width changed at emulated time ``t_us``."""

    t_us: float
    channel: int
    width_us: float


class EmulatedUno:
    """The firmware on simavr: a pyserial port to it and the harness's event log."""

    def __init__(
        self,
        workdir: Path,
        output: str = "pca9685",
        *extra: str,
        link: Path | None = None,
        open_port: bool = True,
    ) -> None:
        """Start the harness; ``link`` is the pty's symlink (default ``workdir/uno-pty``).

        With ``open_port=False`` the test does not open the pty itself (a driver will).
        """
        self.log_path = workdir / "emulator.log"
        self.link = link or workdir / "uno-pty"
        self.stderr_path = workdir / "emulator.stderr"
        with open(self.stderr_path, "wb") as err:
            self.proc = subprocess.Popen(
                [
                    str(HARNESS),
                    "--elf",
                    str(ELF[output]),
                    "--output",
                    output,
                    "--log",
                    str(self.log_path),
                    "--pty-link",
                    str(self.link),
                    "--stack-from",
                    hex(static_ram_end(ELF[output])),
                    *extra,
                ],
                stdout=subprocess.PIPE,
                stderr=err,
                text=True,
            )
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            if line.startswith("pty "):
                break
        else:
            raise RuntimeError(f"harness exited: {self.stderr_path.read_text()}")
        self.port = serial.Serial(str(self.link), 115200, timeout=0.05) if open_port else None
        self.decoder = replies.ReplyDecoder()
        self.sent_bytes = 0
        self.seq = 0
        self.unanswered: list[replies.Reply] = []

    def opened(self) -> serial.Serial:
        """The test's own pyserial port to the pty (started with ``open_port=True``)."""
        assert self.port is not None, "this emulated Uno was started without a port of its own"
        return self.port

    def next_seq(self) -> int:
        """A fresh sequence number (wraps at 65536)."""
        self.seq = (self.seq + 1) & 0xFFFF
        return self.seq

    def write(self, data: bytes) -> int:
        """Send raw bytes; returns how many bytes were sent in total so far."""
        port = self.opened()
        port.write(data)
        port.flush()
        self.sent_bytes += len(data)
        return self.sent_bytes

    def read_replies(self, timeout: float) -> list[replies.Reply]:
        """Replies that arrive within ``timeout`` seconds (wall time)."""
        deadline = time.monotonic() + timeout
        out: list[replies.Reply] = []
        while time.monotonic() < deadline:
            port = self.opened()
            out += self.decoder.feed(port.read(port.in_waiting or 1))
        return out

    def request(self, frame: bytes, timeout: float = 3.0) -> replies.Reply:
        """Send a command frame and return the reply carrying its SEQ."""
        seq = int.from_bytes(frame[2:4], "little")
        self.write(frame)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            port = self.opened()
            for reply in self.decoder.feed(port.read(port.in_waiting or 1)):
                if reply.seq == seq:
                    return reply
                self.unanswered.append(reply)
        raise TimeoutError(f"no reply to {frame.hex()} within {timeout} s")

    def wait_ready(self, timeout: float = 10.0) -> replies.Version:
        """PING until VERSION comes back (pyserial flushes input on open: no boot banner)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                reply = self.request(proto.ping(0), timeout=0.5)
            except TimeoutError:
                continue
            assert isinstance(reply, replies.Version), reply
            return reply
        raise TimeoutError("the emulated Uno does not answer PING")

    def status(self) -> replies.Status:
        """Its STATUS reply."""
        reply = self.request(proto.status(0))
        assert isinstance(reply, replies.Status), reply
        return reply

    def events(self, kind: str) -> list[list[str]]:
        """Log lines of one kind, split: ``[t_us, ...]``."""
        lines = self.log_path.read_text().splitlines()
        return [line.split()[1:] for line in lines if line.startswith(kind + " ")]

    def pulses(self) -> list[Pulse]:
        """Every pulse-width change so far."""
        return [Pulse(float(t), int(ch), float(w)) for t, ch, w in self.events("pwm")]

    def widths(self) -> dict[int, float]:
        """The latest width of every channel seen."""
        return {p.channel: p.width_us for p in self.pulses()}

    def rx_time_us(self, byte_count: int) -> float:
        """Emulated time at which the ``byte_count``-th byte sent is complete in the UART."""
        rx = self.events("rx")
        assert len(rx) >= byte_count, f"only {len(rx)} of {byte_count} bytes reached the UART"
        return float(rx[byte_count - 1][0])

    def wait_for(self, what: Callable[[], bool], timeout: float = 5.0) -> None:
        """Poll until ``what()`` holds (wall time timeout; assertions use emulated time)."""
        deadline = time.monotonic() + timeout
        while not what():
            if time.monotonic() > deadline:
                raise TimeoutError(f"condition not met in {timeout} s; log:\n{self.tail()}")
            time.sleep(0.01)

    def tail(self, lines: int = 40) -> str:
        """The end of the harness log, for failure messages."""
        return "\n".join(self.log_path.read_text().splitlines()[-lines:])

    def stack_use(self) -> tuple[int, int]:
        """After :meth:`close`: (deepest stack use, RAM never touched), bytes."""
        (line,) = self.events("stack")
        return int(line[1]), int(line[2])

    def close(self) -> int:
        """Stop the harness; returns its exit status."""
        if self.port is not None:
            self.port.close()
        self.proc.terminate()
        try:
            return self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            return self.proc.wait()
