"""A performer's calibration as F and T load it, confirmed once per process in the log."""

from __future__ import annotations

import logging
from pathlib import Path

from facesynth.runtime.calibration import Calibration, load_calibration, resolve_calibration

#: Calibration files already confirmed in the log (F and T of one process load the same one).
_CONFIRMED: set[Path] = set()


def build_calibration(name: str | None) -> Calibration | None:
    """The calibration called ``name``, if any; the file it came from, the performer and when it
    was made are logged once per process (logger ``facesynth.calibration``)."""
    if not name:
        return None
    calibration = load_calibration(name)
    path = resolve_calibration(name).resolve()
    if path not in _CONFIRMED:
        _CONFIRMED.add(path)
        logging.getLogger("facesynth.calibration").info(
            "calibration %s: %s (performer %s, made %s)",
            name,
            path,
            calibration.name,
            calibration.created or "at an unrecorded time",
        )
    return calibration
