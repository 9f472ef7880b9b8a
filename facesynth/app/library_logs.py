"""OpenCV's own logger, kept quiet unless ``--log-level DEBUG`` is given.

OpenCV writes ``[ WARN:0@0.014] global cap_v4l.cpp…`` lines to the terminal from its C++
logger (``cv::utils::logging``), e.g. when a camera index does not open, before facesynth's own
one-line error says the same. Its level is read once from ``OPENCV_LOG_LEVEL`` when ``cv2`` is
imported and set afterwards with ``cv2.utils.logging.setLogLevel``. :func:`quiet_libraries`
does both, so it holds whether ``cv2`` is imported later (as most commands do) or already is
(several commands in one process). FFmpeg's level is read when OpenCV first opens a video, so
only the variable sets it. A variable the user set is left alone.

LiteRT's chatter goes to fd 2 from native code and is handled where interpreters are made
(:mod:`facesynth.runtime.native_stderr`).
"""

from __future__ import annotations

import logging
import os
import sys

__all__ = ["LEVELS", "quiet_libraries"]

#: Per variable OpenCV reads: (its value below DEBUG, its value with DEBUG; None: unset, for
#: OpenCV's default). ``OPENCV_FFMPEG_LOGLEVEL`` is FFmpeg's ``av_log`` level inside OpenCV's
#: video reader (-8 quiet): a truncated video's ``[h264 @ …] Invalid NAL unit size`` lines.
LEVELS: dict[str, tuple[str, str | None]] = {
    "OPENCV_LOG_LEVEL": ("ERROR", "WARNING"),
    "OPENCV_FFMPEG_LOGLEVEL": ("-8", None),
}
_OURS = "FACESYNTH_SET_"  # + variable: what a facesynth parent process set it to
# The user's own settings at start win (not those inherited from a facesynth parent).
_USER_SET = {
    name
    for name in LEVELS
    if name in os.environ and os.environ.get(_OURS + name) != os.environ[name]
}
_CV2_LEVELS = {"ERROR": 2, "WARNING": 3}  # cv2.utils.logging.LOG_LEVEL_ERROR / _WARNING


def quiet_libraries(log_level: str) -> None:
    """Set OpenCV's log levels for this process (and the processes it starts) from
    facesynth's ``--log-level``: OpenCV's own defaults with DEBUG, quiet otherwise (OpenCV's
    logger still shows its errors)."""
    debug = logging.getLevelName(log_level) == logging.DEBUG
    for name, values in LEVELS.items():
        value = values[debug]
        if name in _USER_SET:
            continue
        if value is None:
            os.environ.pop(name, None)
            os.environ.pop(_OURS + name, None)
        else:
            os.environ[name] = os.environ[_OURS + name] = value
    cv2 = sys.modules.get("cv2")
    if cv2 is not None and "OPENCV_LOG_LEVEL" not in _USER_SET:
        cv2.utils.logging.setLogLevel(_CV2_LEVELS["WARNING" if debug else "ERROR"])
