"""``facesynth console``'s own checks: the page address, one console per rig on a computer,
a calibration source that cannot be what it says."""

from __future__ import annotations

from pathlib import Path

import pytest

from facesynth.app.cli import build_parser
from facesynth.app.console.command import check_source, lock_path, parse_page, rig_lock
from facesynth.app.nodes import SensorNode
from facesynth.app.stage_args import apply_arguments
from facesynth.app.wiring import OptionError


@pytest.mark.parametrize(
    ("text", "address"),
    [("127.0.0.1:8095", ("127.0.0.1", 8095)), ("[::1]:0", ("::1", 0)), ("host:1", ("host", 1))],
)
def test_a_page_address(text: str, address: tuple[str, int]) -> None:
    assert parse_page(text) == address


@pytest.mark.parametrize(
    "text", ["8095", ":8095", "host:", "host:http", "host:70000", "host:²", "host:٣"]
)
def test_a_bad_page_address(text: str) -> None:
    with pytest.raises(OptionError, match="is not HOST:PORT"):
        parse_page(text)


def test_a_second_console_on_the_same_rig_is_refused(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))
    with rig_lock("bench"):
        assert lock_path("bench").read_text().strip().isdigit()  # who holds it
        refused = pytest.raises(OptionError, match="another facesynth console runs rig 'bench'")
        with refused, rig_lock("bench"):
            pass
        with rig_lock("other"):  # another rig is free
            pass
    with rig_lock("bench"):  # let go when the first ended
        pass


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--video", "nowhere.mp4"], "--video nowhere.mp4: no such file"),
        (["--camera", "-3"], "a device index is 0 or more"),
    ],
)
def test_a_calibration_source_is_checked_at_start(argv: list[str], message: str) -> None:
    args = build_parser().parse_args(["console", *argv])
    _, config = apply_arguments("sensor", SensorNode(), args)
    with pytest.raises(ValueError, match=message):
        check_source(config)


def test_the_console_listens_on_loopback_by_default() -> None:
    args = build_parser().parse_args(["console"])
    assert parse_page(args.page) == ("127.0.0.1", 8095)
