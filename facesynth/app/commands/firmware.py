"""``facesynth firmware``: build or flash the Arduino servo firmware (implemented in
:mod:`facesynth.app.firmware`)."""

from __future__ import annotations

from facesynth.app.command_registry import Command
from facesynth.app.firmware import add_firmware_arguments, cmd_firmware

HELP = "the Arduino Uno servo firmware: build it (gcc-avr) or flash it to a board (avrdude)"

COMMANDS = (Command("firmware", HELP, cmd_firmware, add_firmware_arguments),)
