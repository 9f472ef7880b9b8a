"""T's closed loop in a chain: ``--robot-rig RIG`` or ``--robot-camera CAMERA`` (and
``--loop-state FILE``) on the translator node, checked when the node is built.

With ``--robot-camera``, the robot's camera is tracked in T's own process
(:mod:`facesynth.app.stages.robot_camera`).

The robot's camera runs as a chain of its own on rig ``RIG`` (a sensor on the camera, points,
features: ``facesynth run`` of a graph with those three nodes, as ``facesynth learn`` runs them
on rig ``self``); T reads that rig's ``…/features`` as the robot's face
(:mod:`facesynth.services.translator.robot_face`) and corrects its commands through the learned
profile's self-model (:mod:`facesynth.services.translator.closed_loop`). What the loop learns is
kept in ``--loop-state`` (default: beside the learned profile, ``NAME.loop``) and read back when
the node starts again.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from facesynth.app.arguments import OptionError
from facesynth.runtime import keys
from facesynth.runtime.profiles.loading import ProfileError, resolve_profile
from facesynth.services.translator.core import TranslationError, Translator
from facesynth.services.translator.loop_state import (
    LoopStateError,
    load_loop_state,
    loop_state_path,
)
from facesynth.services.translator.robot_face import LocalFaces, RobotFace

__all__ = ["robot_face"]


def robot_face(
    translator: Translator,
    robot_rig: str | None,
    profile: str | None,
    loop_state: str | None,
    robot_camera: str | None = None,
) -> RobotFace | None:
    """Close ``translator``'s loop through rig ``robot_rig``'s features, or through the
    camera ``robot_camera`` tracked in this process (neither: open loop), resuming what was
    kept in ``loop_state`` (default: beside the profile ``profile``'s file);
    :class:`OptionError` in one line when it cannot be closed."""
    if robot_rig is not None and robot_camera is not None:
        raise OptionError(
            "--robot-rig and --robot-camera are two ways to see the robot's face: give one"
        )
    flag = "--robot-rig" if robot_camera is None else "--robot-camera"
    if robot_rig is None and robot_camera is None:
        if loop_state is not None:
            raise OptionError("--loop-state goes with --robot-rig or --robot-camera")
        return None
    key, local = None, None
    try:
        if robot_rig is not None:
            key = keys.stage_key(keys.check_name(robot_rig, "--robot-rig"), "features")
        else:
            assert robot_camera is not None
            local = _tracked(robot_camera)
    except ValueError as exc:
        raise OptionError(str(exc)) from None
    learned = translator.profile.learned
    if learned is None:
        raise OptionError(
            f"{flag}: profile {translator.profile.name} is not learned: the closed loop "
            "corrects a learned profile through its self-model (facesynth learn)"
        )
    path = Path(loop_state) if loop_state is not None else _beside(profile)
    try:
        state = load_loop_state(path, learned) if path is not None else None
        translator.close_loop(state=state)
    except (LoopStateError, TranslationError) as exc:
        raise OptionError(f"{flag}: {exc}") from None
    return RobotFace(key=key, state_path=path, local=local)


def _tracked(camera: str) -> Callable[[], LocalFaces]:
    """The robot's camera ``camera`` tracked in this process, once the service starts."""
    from facesynth.app.stages.robot_camera import RobotCamera, camera_source

    opener = camera_source(camera)  # checked now: a wrong value is one line
    return lambda: RobotCamera(opener)


def _beside(profile: str | None) -> Path | None:
    """``NAME.loop`` beside the learned profile file ``profile`` names (None: none named)."""
    if profile is None:
        return None
    try:
        return loop_state_path(resolve_profile(profile))
    except ProfileError:  # pragma: no cover - the profile was loaded already
        return None
