"""A simulated robot head: a real face photo moved by messy actuators, for tests and demos.

:mod:`.head` is the pure core (:class:`SimHead`: ``command``, ``step``, ``pulses``,
``render``), :mod:`.config` reads head files (:func:`load_head`), :mod:`.effects` and
:mod:`.renderer` move the bundled photo (:mod:`.photo`), :mod:`.maestro` is the Pololu Maestro
protocol the head speaks and :mod:`.server` the pseudo-terminal and the MJPEG camera of
``facesynth simhead``.
"""

from .config import Actuator, HeadConfig, HeadError, head_names, load_head, parse_head
from .effects import EFFECTS
from .head import SimHead, response

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
