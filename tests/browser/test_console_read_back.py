"""The rig console in a real headless Chromium with servos that read themselves back: sixteen
emulated Dynamixel XL430s on a pty (``--driver dynamixel``). The page shows each servo's measured
position beside the commanded one; a jog past where a servo is blocked shows it stopped short,
then its overload fault, while the others go on."""

from __future__ import annotations

import asyncio
import re
import sys
from pathlib import Path
from typing import Any

import pytest

TESTS = Path(__file__).resolve().parents[1]
if str(TESTS / "control") not in sys.path:
    sys.path.insert(0, str(TESTS / "control"))

from facesynth_processes import Processes  # noqa: E402
from fake_devices.dynamixel import FakeDynamixelBus  # noqa: E402

from facesynth.runtime.profiles import load_profile  # noqa: E402
from facesynth.services.control.drivers.bus_servo.native import Model, native_servo  # noqa: E402
from tests.browser.conftest import js, wait_js  # noqa: E402

pytestmark = pytest.mark.browser

PROFILE = load_profile("paper16")
X = Model("XL430-W250", 1060, 4096, 360.0)
JOG = (
    "const r = document.querySelector('tr[data-servo=\"0\"] input.jog');"
    " r.value = arguments[0]; r.dispatchEvent(new Event('input')); return r.value;"
)
CELL = "document.querySelector('tr[data-servo=\"{}\"] td.measured')"


async def test_the_page_shows_measured_positions_and_a_stalled_servo_s_fault(
    browser: Any, processes: Processes, tmp_path: Path
) -> None:
    first = PROFILE.servos[0]
    bus = FakeDynamixelBus(tmp_path / "ttyDXL", list(range(1, 17)))
    blocked_us = first.neutral_us + 80  # the skin holds it there
    bus.plug()
    bus.servos[first.channel + 1].stall_at = native_servo(first, X).native(blocked_us)
    try:
        processes(
            "console", "--profile", "paper16", "--driver", "dynamixel", "--port", str(bus.link),
            "--baud", "1000000", "--page", "127.0.0.1:0", "--listen", "tcp/127.0.0.1:0",
            "--rig", "readback", name="console",
        )  # fmt: skip
        line = await asyncio.to_thread(processes.wait_for_line, "console", "facesynth console", 60)
        found = re.search(r"(http://\S+)#token=(\S+)", line)
        assert found is not None, line
        base, token = found.groups()
        await asyncio.to_thread(browser.get, f"{base}#token={token}")
        await wait_js(browser, "window.facesynth.status === 'open' && window.facesynth.trusted")
        await wait_js(browser, "window.facesynth.servos.length === 16")
        every = "window.facesynth.measured.length === 16 && window.facesynth.measured.every("
        await wait_js(browser, every + "(m, i) => Math.abs(m - window.facesynth.positions[i]) < 3)")
        assert await js(browser, f"return {CELL.format(1)}.textContent") == "1500"
        target = first.neutral_us + 200
        await js(browser, JOG, target)
        await wait_js(browser, f"window.facesynth.positions[0] === {target}")
        await wait_js(browser, "(window.facesynth.faults[0] || '').includes('overload')")
        measured = await js(browser, "return window.facesynth.measured[0]")
        assert abs(measured - blocked_us) < 3  # stopped short of the command, where it is held
        cell = await js(browser, f"return {CELL.format(0)}.textContent")
        assert cell.startswith(str(round(measured))) and "overload" in cell
        assert await js(browser, f"return {CELL.format(0)}.classList.contains('fault')")
        mark = "document.querySelector('#bars .bar .measured')"
        assert await js(browser, f"return !{mark}.hidden")
        assert await js(browser, "return window.facesynth.faults.filter((f) => f).length") == 1
    finally:
        processes.stop()
        bus.close()
