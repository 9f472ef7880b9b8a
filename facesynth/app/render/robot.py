"""The robot's camera panel of the side-by-side video: a simulated head driven by a profile.

``facesynth render --robot-head simhead16 --profile X`` shows performer | robot (| bars): each
performer frame's features go through T (the profile) and C onto the simulated head, exactly
as ``facesynth bench robot`` drives it (:class:`facesynth.app.bench.robot.RobotLoop`: the
head's neutral first, then C's speed limits on the robot's clock), and the panel is the
head's camera image at that frame with the points the tracker finds on it; the bars then show
the positions C sent the head. With ``--closed-loop`` (a learned profile) the head is driven
with T's loop closed through its own camera
(:class:`~facesynth.app.engine.closed_robot_loop.ClosedRobotLoop`, as ``bench robot
--closed-loop`` drives it), beside a second head driven by the same profile in open loop.
"""

from __future__ import annotations

import contextlib

import cv2
import numpy as np

from facesynth.app.engine.closed_robot_loop import ClosedRobotLoop
from facesynth.app.engine.robot_loop import RobotLoop
from facesynth.app.render.draw import draw_landmarks, draw_title, panel
from facesynth.runtime.calibration import Calibration
from facesynth.runtime.profiles import Profile
from facesynth.schemas.messages import Features, Points
from facesynth.services.features.core import FeatureError, ibug_points

__all__ = ["RobotPanel", "robot_image"]

#: Height of the darkened band under the panel's title (pixels).
TITLE_BAND = 26


class RobotPanel:
    """One simulated head (``head``: bundled, by name, or a head file) following the performer
    through one profile."""

    def __init__(
        self,
        head: str,
        profile: Profile,
        *,
        fps: float,
        calibration: Calibration | None = None,
        closed: bool | None = None,
    ) -> None:
        """``closed``: True, T's loop closed through the head's camera (a learned profile,
        else :class:`~facesynth.app.engine.robot_loop.RobotError`); False, the same in open
        loop, said in the title; None, the open loop with a plain title."""
        self.title = f"robot: {head} / {profile.name}"
        if closed is not None:
            self.title += ", closed loop" if closed else ", open loop"
        from facesynth.app.simhead import SimHead, load_head

        loop = ClosedRobotLoop if closed else RobotLoop
        self.loop: RobotLoop = loop(
            profile, SimHead(load_head(head)), fps=fps, calibration=calibration
        )

    @property
    def positions(self) -> dict[str, float]:
        """Where C last sent the head's servos."""
        return self.loop.control.positions

    def step(self, features: Features) -> tuple[np.ndarray, Features]:
        """The head's camera image after this performer frame, and the robot's features."""
        return self.loop.step(features)

    def picture(self, image: np.ndarray, height: int, width: int) -> np.ndarray:
        """The camera image scaled into a ``height`` x ``width`` panel, with the points the
        tracker found on it and the panel's title."""
        return robot_image(image, self.loop.points, height, width, self.title)


def robot_image(
    image: np.ndarray, points: Points | None, height: int, width: int, title: str
) -> np.ndarray:
    """``image`` fitted into ``height`` x ``width`` (centred), its landmarks drawn (``points``:
    the tracker's Points on ``image``, or None)."""
    scale = min(height / image.shape[0], width / image.shape[1])
    size = (max(1, round(image.shape[1] * scale)), max(1, round(image.shape[0] * scale)))
    scaled = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
    landmarks = None
    if points is not None and points.face:
        with contextlib.suppress(FeatureError):
            landmarks = ibug_points(points) * scale
    draw_landmarks(scaled, landmarks)
    out = panel(height, width)
    y, x = (height - size[1]) // 2, (width - size[0]) // 2
    out[y : y + size[1], x : x + size[0]] = scaled
    out[:TITLE_BAND] = out[:TITLE_BAND] // 3  # darkened, so the title reads on a light wall
    draw_title(out, title)
    return out
