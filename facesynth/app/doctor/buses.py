"""Who answers on a control driver's own bus: ids and models of smart servos, an I2C board.

The serial boards are told apart by doctor's own questions (:mod:`.boards`); a driver that
owns a bus (Dynamixel, Feetech, the PCA9685 on I2C) lists what it finds itself, through
:meth:`~services.control.drivers.base.ServoDriver.found`. For each control node whose driver
does, doctor builds the driver as ``run`` would, opens it once read-only
(``connect_once(query_only=True)``: nothing is configured, nothing moves), lists each device on
its line and closes it. A bus that cannot be opened, or a device that cannot serve the profile
(another model than it expects), is a line to fix.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Iterable
from typing import Any

import msgspec

from facesynth.app.doctor.report import Finding
from facesynth.runtime.plugins import PluginError
from facesynth.runtime.profiles import ProfileError, load_profile
from facesynth.services.control.drivers.base import DriverError, FoundDevice, ServoDriver
from facesynth.services.control.drivers.registry import DRIVERS

FAMILY = "bus"
FIX = (
    "check the bus's wiring and power, and the driver's options (its port or bus, baud rate "
    "or address); stop the control service first (it holds the bus)"
)


def lists_devices(config: msgspec.Struct | None) -> bool:
    """Whether the driver ``config`` builds can list what is on its bus."""
    if config is None:
        return False
    tag = str(config.__struct_config__.tag)
    if tag not in DRIVERS:
        return False
    factory: Any = DRIVERS.get(tag).factory
    return getattr(factory, "found", ServoDriver.found) is not ServoDriver.found


def bus_findings(profiles: Iterable[tuple[str, str, msgspec.Struct | None]]) -> list[Finding]:
    """One line per device found on each control node's bus (``needs.profiles`` entries: the
    node, its profile, its driver config); nothing for drivers that have no bus to list."""
    findings: list[Finding] = []
    for node, profile_name, config in profiles:
        if not lists_devices(config):
            continue
        assert config is not None
        subject = f"control node {node} ({config.__struct_config__.tag})"
        try:
            profile = load_profile(profile_name)
        except (ProfileError, OSError, ValueError):
            continue  # the profile's own line says what is wrong with it
        try:
            driver = DRIVERS.build(config, profile)
            devices = asyncio.run(_ask(driver))
        except (DriverError, PluginError, ValueError, OSError) as exc:
            findings.append(Finding(FAMILY, subject, str(exc), good=False, needed=True, fix=FIX))
            continue
        if not devices:
            findings.append(
                Finding(FAMILY, subject, "nothing answers", good=False, needed=True, fix=FIX)
            )
        findings += [_finding(subject, device) for device in devices]
    return findings


async def _ask(driver: ServoDriver) -> list[FoundDevice]:
    try:
        await driver.connect_once(query_only=True)
        return await driver.found()
    finally:
        with contextlib.suppress(Exception):
            await driver.close()


def _finding(subject: str, device: FoundDevice) -> Finding:
    where = f"{subject} {device.address}"
    text = device.model + (f" (for {device.servo})" if device.servo else " (no servo uses it)")
    if device.problem:
        return Finding(FAMILY, where, f"{text}: {device.problem}", good=False, needed=True, fix=FIX)
    return Finding(FAMILY, where, text, good=True if device.servo else None)
