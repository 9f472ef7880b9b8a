"""OpenCV's logger follows facesynth's --log-level: quiet unless DEBUG."""

from __future__ import annotations

import cv2
import pytest

from facesynth.app import library_logs
from facesynth.app.library_logs import quiet_libraries


@pytest.fixture(autouse=True)
def _opencv_level_restored(monkeypatch: pytest.MonkeyPatch) -> object:
    for name in library_logs.LEVELS:  # set, then deleted: restored as they were afterwards
        for variable in (name, "FACESYNTH_SET_" + name):
            monkeypatch.setenv(variable, "")
            monkeypatch.delenv(variable)
    monkeypatch.setattr(library_logs, "_USER_SET", set())
    level = cv2.utils.logging.getLogLevel()
    yield
    cv2.utils.logging.setLogLevel(level)


@pytest.mark.parametrize("log_level", ["INFO", "WARNING", "ERROR"])
def test_below_debug_opencv_shows_only_errors(log_level: str) -> None:
    quiet_libraries(log_level)
    assert cv2.utils.logging.getLogLevel() == cv2.utils.logging.LOG_LEVEL_ERROR
    assert library_logs.os.environ["OPENCV_LOG_LEVEL"] == "ERROR"  # for a later import, children
    assert library_logs.os.environ["OPENCV_FFMPEG_LOGLEVEL"] == "-8"  # read on the first video


def test_debug_gives_opencv_its_defaults_back() -> None:
    quiet_libraries("INFO")
    quiet_libraries("DEBUG")
    assert cv2.utils.logging.getLogLevel() == cv2.utils.logging.LOG_LEVEL_WARNING
    assert library_logs.os.environ["OPENCV_LOG_LEVEL"] == "WARNING"
    assert "OPENCV_FFMPEG_LOGLEVEL" not in library_logs.os.environ


def test_a_users_own_setting_is_left_alone(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("OPENCV_LOG_LEVEL", "VERBOSE")
    monkeypatch.setattr(library_logs, "_USER_SET", {"OPENCV_LOG_LEVEL"})
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_VERBOSE)
    quiet_libraries("INFO")
    assert library_logs.os.environ["OPENCV_LOG_LEVEL"] == "VERBOSE"
    assert cv2.utils.logging.getLogLevel() == cv2.utils.logging.LOG_LEVEL_VERBOSE
