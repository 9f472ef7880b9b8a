"""The rig console in a real headless Chromium, against our firmware on the emulated Uno
(simavr, PCA9685 pulses measured on its I2C bus): the page with the token moves a servo with
its slider through C, sets the servo's maximum from where it stands and saves a profile that
reloads identically (the previous file kept); a page without the token only watches; when the
console stops, the page says it is disconnected and C has brought the face back to neutral."""

from __future__ import annotations

import asyncio
import re
import shutil
import sys
from pathlib import Path
from typing import Any

import msgspec
import pytest

TESTS = Path(__file__).resolve().parents[1]
for folder in ("control", "firmware"):
    if str(TESTS / folder) not in sys.path:
        sys.path.insert(0, str(TESTS / folder))

from board_fixtures import uno  # noqa: E402
from facesynth_processes import Processes  # noqa: E402
from uno_rig import UnoRig, firmware_ready  # noqa: E402

from facesynth.runtime.profiles import PACKAGE_DIR, load_profile  # noqa: E402
from tests.browser.conftest import js, wait_js  # noqa: E402

pytestmark = pytest.mark.browser
__all__ = ["firmware_ready", "uno"]

JOG = (
    "const r = document.querySelector('tr[data-servo=\"0\"] input.jog');"
    " r.value = arguments[0]; r.dispatchEvent(new Event('input')); return r.value;"
)


async def test_a_slider_moves_the_pulse_and_a_saved_profile_reloads_identically(
    browser: Any, uno: UnoRig, processes: Processes, tmp_path: Path
) -> None:
    path = tmp_path / "head.toml"
    shutil.copy(Path(PACKAGE_DIR) / "head16_hardware.toml", path)
    original = load_profile(str(path))
    first = original.servos[0]
    processes(
        "console", "--profile", str(path), "--driver", "arduino", "--port", str(uno.port),
        "--page", "127.0.0.1:0", "--listen", "tcp/127.0.0.1:0", "--rig", "consoletest",
        name="console",
    )  # fmt: skip
    line = await asyncio.to_thread(processes.wait_for_line, "console", "facesynth console", 60)
    found = re.search(r"(http://\S+)#token=(\S+)", line)
    assert found is not None, line
    base, token = found.groups()
    await uno.settle({first.channel: first.neutral_us}, timeout=20)  # C starts at neutral

    await asyncio.to_thread(browser.get, f"{base}#token={token}")
    await wait_js(browser, "window.facesynth.status === 'open' && window.facesynth.trusted")
    await wait_js(browser, "window.facesynth.servos.length === 16")
    board = "document.getElementById('board').textContent"
    await wait_js(browser, f"{board}.includes('connected to ' + {str(uno.port)!r})")  # C's note
    table = "document.querySelector('#stats tbody').textContent"
    await wait_js(browser, f"{table}.includes('connected to ' + {str(uno.port)!r})")  # its column
    await js(browser, JOG, 1720)
    await uno.settle({first.channel: 1720.0}, timeout=10)  # the PCA9685's pulse, to a step
    await wait_js(browser, "window.facesynth.positions[0] === 1720")
    await wait_js(browser, "document.querySelector('#bars .bar .value').textContent === '1720'")
    await js(browser, "document.querySelector('tr[data-servo=\"0\"] button.here-max').click()")
    await wait_js(browser, "window.facesynth.servos[0].max === 1720")
    await js(browser, "document.getElementById('save').click()")
    await wait_js(browser, "window.facesynth.saved !== null")

    expected = msgspec.structs.replace(
        original, servos=[msgspec.structs.replace(first, max_us=1720.0), *original.servos[1:]]
    )
    assert load_profile(str(path)) == expected
    assert (tmp_path / "head.toml.bak").read_text() == (
        Path(PACKAGE_DIR) / "head16_hardware.toml"
    ).read_text()
    await uno.settle({first.channel: first.neutral_us}, timeout=10)  # C restarted: neutral

    await asyncio.to_thread(browser.get, base)  # no token: a page that only watches
    await wait_js(browser, "window.facesynth.status === 'open' && window.facesynth.errors.length")
    assert "no token" in await js(browser, "return window.facesynth.errors[0]")
    await js(browser, JOG, 1300)
    await wait_js(browser, "window.facesynth.errors.some((e) => e.includes('no token'))")
    await asyncio.sleep(0.3)
    assert uno.shows({first.channel: first.neutral_us})

    await asyncio.to_thread(browser.get, "about:blank")  # (a new #fragment alone: no reload)
    await asyncio.to_thread(browser.get, f"{base}#token={token}")
    await wait_js(browser, "window.facesynth.status === 'open' && window.facesynth.trusted")
    await js(browser, JOG, 1300)
    await uno.settle({first.channel: 1300.0}, timeout=10)
    processes.stop()  # the console stops: C returns the face to neutral, the page says so
    await uno.settle({first.channel: first.neutral_us}, timeout=10)
    await wait_js(browser, "window.facesynth.status === 'closed'")
    assert "Disconnected" in await js(
        browser, "return document.getElementById('banner').textContent"
    )
    assert await js(browser, "return !document.getElementById('banner').hidden")
