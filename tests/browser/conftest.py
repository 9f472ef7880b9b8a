"""A real headless Chromium (Debian's chromium + chromium-driver) driven by selenium.

These tests fail, never skip, when the browser is missing: ``.ci/run`` installs it.
"""

from __future__ import annotations

import asyncio
import os
import shutil
import tempfile
import time
from collections.abc import Iterator
from typing import Any

import pytest
from host_requirements import require_packages

CHROMIUM = os.environ.get("FACESYNTH_CHROMIUM", "/usr/bin/chromium")
CHROMEDRIVER = os.environ.get("FACESYNTH_CHROMEDRIVER", "/usr/bin/chromedriver")
FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--window-size=1300,900",
)


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    """One Chromium for a test module, with a fresh profile folder."""
    require_packages(
        "the browser tests", "browser", ((CHROMIUM, "chromium"), (CHROMEDRIVER, "chromium-driver"))
    )
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    profile = tempfile.mkdtemp(prefix="facesynth-chromium-")
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in (*FLAGS, f"--user-data-dir={profile}"):
        options.add_argument(flag)
    driver = webdriver.Chrome(options=options, service=Service(executable_path=CHROMEDRIVER))
    driver.set_page_load_timeout(30)
    try:
        yield driver
    finally:
        driver.quit()
        shutil.rmtree(profile, ignore_errors=True)


async def js(browser: Any, script: str, *args: Any) -> Any:
    """Run ``script`` in the page (off the event loop, which serves the page meanwhile)."""
    return await asyncio.to_thread(browser.execute_script, script, *args)


async def wait_js(browser: Any, condition: str, timeout: float = 15.0) -> Any:
    """Poll ``return (condition)`` until it is truthy; fail with the page's state if not."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = await js(browser, f"try {{ return ({condition}); }} catch (e) {{ return null; }}")
        if value:
            return value
        await asyncio.sleep(0.05)
    state = await js(browser, "return JSON.stringify(window.facesynth || null)")
    raise AssertionError(f"the page never had {condition}; its state: {str(state)[:400]}")
