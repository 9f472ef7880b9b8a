"""A vendor SDK's serial port in memory, for fuzzing what the drivers read through the SDKs."""

from __future__ import annotations

from typing import Any


class MemoryPort:
    """The SDK's port, answering with ``stream`` in chunks; silent once it is used up."""

    def __init__(self, stream: bytes, chunk: int) -> None:
        self.stream = stream
        self.chunk = chunk
        self.is_using = False
        self.baudrate = 1000000

    def clearPort(self) -> None:
        pass

    def writePort(self, packet: Any) -> int:
        return len(packet)

    def readPort(self, length: int) -> bytes:
        out, self.stream = (
            self.stream[: min(length, self.chunk)],
            self.stream[min(length, self.chunk) :],
        )
        return out

    def setPacketTimeout(self, _: int) -> None:
        pass

    def isPacketTimeout(self) -> bool:
        return not self.stream

    def getBaudRate(self) -> int:
        return self.baudrate
