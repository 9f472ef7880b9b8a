"""A simulated robot head: a real face photo moved by messy actuators, for tests and demos.

:mod:`.head` is the pure core (:class:`SimHead`: ``command``, ``step``, ``pulses``,
``render``), :mod:`.config` reads head files and :mod:`.heads` finds them (:func:`load_head`:
bundled, a file, or generated from a seed by :mod:`.generated`), :mod:`.effects` and
:mod:`.renderer` move the bundled photo (:mod:`.photo`), :mod:`.maestro` is the Pololu Maestro
protocol the head speaks and :mod:`.server` the pseudo-terminal and the MJPEG camera of
``facesynth simhead`` (:mod:`.command`).

The names below are imported on first use, so ``facesynth --help`` does not load OpenCV.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .config import Actuator, HeadConfig, HeadError, parse_head
    from .effects import EFFECTS
    from .head import SimHead, response
    from .heads import head_names, load_head

__all__ = [
    "EFFECTS",
    "Actuator",
    "HeadConfig",
    "HeadError",
    "SimHead",
    "head_names",
    "load_head",
    "parse_head",
    "response",
]

_WHERE = {
    "EFFECTS": "effects",
    "Actuator": "config",
    "HeadConfig": "config",
    "HeadError": "config",
    "head_names": "heads",
    "load_head": "heads",
    "parse_head": "config",
    "SimHead": "head",
    "response": "head",
}


def __getattr__(name: str) -> Any:
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f".{_WHERE[name]}", __name__), name)
