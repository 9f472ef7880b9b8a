"""A fake Arduino Uno bootloader (optiboot, STK500 version 1 subset) on a pty, for avrdude.

From Atmel's AVR061 "STK500 Communication Protocol" and what optiboot implements of it: each
command is a byte, its fixed arguments, then CRC_EOP (0x20); answers start with STK_INSYNC
(0x14) and end with STK_OK (0x10). The flash is a 32 KiB byte array; LOAD_ADDRESS takes a word
address, PROG_PAGE / READ_PAGE a big-endian length and a memory type.
"""

from __future__ import annotations

from pathlib import Path

from fake_devices.pty_device import FakeDevice

INSYNC, OK, NOSYNC, CRC_EOP = 0x14, 0x10, 0x15, 0x20
SIGNATURE = bytes([0x1E, 0x95, 0x0F])  # ATmega328P
# Argument bytes after the command byte (PROG_PAGE: 3 + its length).
ARGS = {0x30: 0, 0x31: 0, 0x41: 1, 0x42: 20, 0x45: 5, 0x50: 0, 0x51: 0, 0x52: 0, 0x55: 2,
        0x56: 4, 0x64: 3, 0x74: 3, 0x75: 0}  # fmt: skip


class FakeOptiboot(FakeDevice):
    """The bootloader of an Uno: answers avrdude and keeps what it writes."""

    def __init__(self, link: Path) -> None:
        super().__init__(link)
        self.reset()

    def reset(self) -> None:
        super().reset()
        self.flash = bytearray(b"\xff" * 32768)
        self.address = 0
        self.pages_written = 0
        self.left_programming = False
        self._packet = bytearray()

    def handle(self, data: bytes) -> bytes:
        out = bytearray()
        for byte in data:
            if not self._packet and byte not in ARGS:
                continue  # noise between commands (avrdude drains and resyncs)
            self._packet.append(byte)
            command = self._packet[0]
            need = ARGS[command]
            if command == 0x64 and len(self._packet) >= 3:
                need = 3 + (self._packet[1] << 8 | self._packet[2])
            if len(self._packet) < need + 2:
                continue
            packet, self._packet = bytes(self._packet), bytearray()
            if packet[-1] != CRC_EOP:
                out.append(NOSYNC)
                continue
            out += bytes([INSYNC]) + self._execute(packet[0], packet[1:-1]) + bytes([OK])
        return bytes(out)

    def _execute(self, command: int, args: bytes) -> bytes:
        if command == 0x41:  # GET_PARAMETER: software version 4.4, anything else 3
            return bytes([{0x81: 4, 0x82: 4}.get(args[0], 3)])
        if command == 0x55:  # LOAD_ADDRESS (words)
            self.address = (args[0] | args[1] << 8) * 2
        elif command == 0x64:  # PROG_PAGE
            data = args[3:]
            if args[2] == ord("F"):
                self.flash[self.address : self.address + len(data)] = data
                self.pages_written += 1
        elif command == 0x74:  # READ_PAGE
            length = args[0] << 8 | args[1]
            return bytes(self.flash[self.address : self.address + length])
        elif command == 0x75:  # READ_SIGN
            return SIGNATURE
        elif command == 0x56:  # UNIVERSAL
            return b"\x00"
        elif command == 0x51:  # LEAVE_PROGMODE
            self.left_programming = True
        return b""
