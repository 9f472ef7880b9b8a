"""facesynth message schemas: msgspec structs for every topic (see ``messages``)."""

from facesynth.schemas.messages import (
    ALL_MESSAGES,
    BabbleSample,
    Features,
    Frame,
    Points,
    PointSet,
    ScoreSet,
    ServiceStats,
    ServoCommands,
)

__all__ = [
    "ALL_MESSAGES",
    "BabbleSample",
    "Features",
    "Frame",
    "PointSet",
    "Points",
    "ScoreSet",
    "ServiceStats",
    "ServoCommands",
]
