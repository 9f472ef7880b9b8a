"""Every Zenoh key expression facesynth uses, in one place.

Data keys are namespaced by rig: ``facesynth/<rig>/<stage>``, where the stages are
``input`` (S), ``points`` (P), ``features`` (F), ``servo_commands`` (T) and ``servo_state``
(C: the positions it actually applied, after its own checks and clamping).

A rig that drives several robots from one performer gives each robot its own command keys:
``facesynth/<rig>/servo_commands/<robot>`` and ``facesynth/<rig>/servo_state/<robot>``
(:data:`ROBOT_STAGES`), so each robot's translator and control interface talk to each other
only, whatever their profiles. Without a robot name the keys stay ``…/servo_commands`` and
``…/servo_state``; :func:`robots_pattern` matches both forms, for observers of every robot.

Beyond the chain, ``facesynth learn`` publishes every settled pose of a babbling robot on
``facesynth/<rig>/babble`` (:data:`APP_KEYS`); no stage consumes it, the recorder keeps it.

Health (liveliness tokens) and stats keys add the service name and an instance id:
``facesynth/<rig>/health/<service>/<instance>`` and ``facesynth/<rig>/stats/<service>/<instance>``.
"""

from __future__ import annotations

import re
from typing import Final, Literal

PREFIX: Final = "facesynth"

Stage = Literal["input", "points", "features", "servo_commands", "servo_state"]
#: ``servo_state`` is what a control interface actually applied (clamped positions).
STAGES: Final[tuple[Stage, ...]] = ("input", "points", "features", "servo_commands", "servo_state")

#: Data keys beyond the chain's stages: ``babble`` (``facesynth learn``'s settled poses).
AppKey = Literal["babble"]
APP_KEYS: Final[tuple[AppKey, ...]] = ("babble",)
#: Every data key of a rig (:func:`stage_key` builds each).
DataKey = Stage | AppKey

SERVICES: Final = ("sensor", "points", "features", "translator", "control")

#: Which stage each service publishes and which it consumes.
PUBLISHES: Final[dict[str, Stage | None]] = {
    "sensor": "input",
    "points": "points",
    "features": "features",
    "translator": "servo_commands",
    "control": "servo_state",
}
CONSUMES: Final[dict[str, Stage | None]] = {
    "sensor": None,
    "points": "input",
    "features": "points",
    "translator": "features",
    "control": "servo_commands",
}

#: Stages keyed per robot when a rig drives several robots (see :func:`stage_key`).
ROBOT_STAGES: Final[tuple[Stage, ...]] = ("servo_commands", "servo_state")

_NAME = re.compile(r"[A-Za-z0-9_.-]{1,64}")


class KeyNameError(ValueError):
    """A rig, service or instance name that cannot be part of a key expression."""


def check_name(value: str, what: str = "rig") -> str:
    """Return ``value`` if it is a valid single key chunk, else raise :class:`KeyNameError`."""
    if not _NAME.fullmatch(value):
        raise KeyNameError(
            f"invalid {what} name {value!r}: use 1-64 letters, digits, '_', '-' or '.'"
        )
    return value


def stage_key(rig: str, stage: DataKey, robot: str | None = None) -> str:
    """Data key of one stage of a rig, e.g. ``facesynth/default/points`` (or of one of the
    :data:`APP_KEYS`, e.g. ``facesynth/default/babble``).

    With ``robot``, the key of that robot's commands or state (only for :data:`ROBOT_STAGES`;
    the stages before the translator are the performer's, shared by every robot):
    ``facesynth/default/servo_commands/head1``.
    """
    if stage not in STAGES and stage not in APP_KEYS:
        known = ", ".join((*STAGES, *APP_KEYS))
        raise KeyNameError(f"unknown stage {stage!r}; known: {known}")
    key = f"{PREFIX}/{check_name(rig)}/{stage}"
    if not robot:
        return key
    if stage not in ROBOT_STAGES:
        raise KeyNameError(
            f"stage {stage!r} is shared by every robot of a rig; only "
            f"{' and '.join(ROBOT_STAGES)} have a key per robot"
        )
    return f"{key}/{check_name(robot, 'robot')}"


def robots_pattern(rig: str, stage: Stage) -> str:
    """Key expression matching a stage's key and, for :data:`ROBOT_STAGES`, every robot's."""
    key = stage_key(rig, stage)
    return f"{key}/**" if stage in ROBOT_STAGES else key


def robot_of(key: str) -> str | None:
    """The robot named in a per-robot command or state key, else ``None`` (an empty or invalid
    robot name too: such a key is no robot's)."""
    parts = key.split("/")
    robot = len(parts) == 4 and parts[0] == PREFIX and parts[2] in ROBOT_STAGES
    return parts[3] if robot and _NAME.fullmatch(parts[3]) else None


def health_key(rig: str, service: str, instance: str) -> str:
    """Liveliness token key of one running service instance."""
    return (
        f"{PREFIX}/{check_name(rig)}/health/{check_name(service, 'service')}/"
        f"{check_name(instance, 'instance')}"
    )


def stats_key(rig: str, service: str, instance: str) -> str:
    """Key on which one service instance publishes its :class:`ServiceStats`."""
    return (
        f"{PREFIX}/{check_name(rig)}/stats/{check_name(service, 'service')}/"
        f"{check_name(instance, 'instance')}"
    )


def health_pattern(rig: str | None = None) -> str:
    """Key expression matching the liveliness tokens of one rig, or of every rig."""
    return f"{PREFIX}/{check_name(rig) if rig else '*'}/health/**"


def stats_pattern(rig: str | None = None) -> str:
    """Key expression matching the stats of one rig, or of every rig."""
    return f"{PREFIX}/{check_name(rig) if rig else '*'}/stats/**"


def parse_service_key(key: str) -> tuple[str, str, str] | None:
    """``(rig, service, instance)`` from a health or stats key, or ``None`` if it is neither."""
    parts = key.split("/")
    if len(parts) == 5 and parts[0] == PREFIX and parts[2] in ("health", "stats"):
        return parts[1], parts[3], parts[4]
    return None
