"""Shared fixtures: a real Zenoh router (a Python session in router mode) on loopback, facesynth
commands as real OS processes."""

from __future__ import annotations

import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest
import zenoh
from facesynth_processes import Processes

from facesynth.runtime.bus.zenoh_bus import ZenohOptions, open_session, router_locators

BROWSER_TESTS = Path(__file__).parent / "browser"


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """A ``browser`` test outside tests/browser is refused: the Makefile runs the browser group as
    ``pytest -m browser tests/browser``, not over the whole tree (22 s of CPU to collect, 3 s)."""
    strays = [
        item.nodeid
        for item in items
        if item.get_closest_marker("browser") and not item.path.is_relative_to(BROWSER_TESTS)
    ]
    if strays:
        raise pytest.UsageError(f"browser tests belong in tests/browser: {', '.join(strays)}")


@pytest.fixture(scope="module")
def zenoh_router() -> Iterator[str]:
    """A Zenoh router on tcp/127.0.0.1 (free port, scouting off); yields its locator."""
    session = open_session(ZenohOptions(mode="router", listen=["tcp/127.0.0.1:0"]))
    try:
        locators = router_locators(session)
        assert locators, "the router reports no locator"
        yield locators[0]
    finally:
        session.close()


@pytest.fixture(autouse=True)
def own_state_dir(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> Path:
    """Each test keeps F's learned state (``$FACESYNTH_STATE``, inherited by the processes it
    starts) in a folder of its own, so no test picks up a neutral another one learned."""
    folder = tmp_path / "facesynth-state"
    monkeypatch.setenv("FACESYNTH_STATE", str(folder))
    return folder


@pytest.fixture
def key_prefix() -> str:
    """A key prefix no other test uses."""
    return f"test/{uuid.uuid4().hex[:12]}"


@pytest.fixture
def rig() -> str:
    """A rig name no other test uses."""
    return f"t{uuid.uuid4().hex[:10]}"


@pytest.fixture
def isolated_home(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> Path:
    """An empty ``tmp_path/home`` as HOME and no ``$FACESYNTH_PROFILES`` or
    ``$FACESYNTH_CALIBRATIONS``: only the shipped profiles and the test's own files are found."""
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.delenv("FACESYNTH_PROFILES", raising=False)
    monkeypatch.delenv("FACESYNTH_CALIBRATIONS", raising=False)
    return home


def client_options(locator: str, mode: str = "peer") -> ZenohOptions:
    """Options for a session connecting to the test router."""
    return ZenohOptions(mode=mode, connect=[locator])


__all__ = ["client_options", "zenoh"]


@pytest.fixture
def processes(tmp_path: Path) -> Iterator[Processes]:
    """A :class:`Processes`; what is still running at the end gets SIGTERM, then SIGKILL."""
    spawner = Processes(tmp_path)
    yield spawner
    spawner.stop()
