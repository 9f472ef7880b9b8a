"""The ``[record]`` extra (mcap, foxglove-sdk), checked where a command first needs it."""

from __future__ import annotations

import importlib


class ExtraMissingError(ValueError):
    """The ``[record]`` extra is not installed."""


def need_record_extra() -> None:
    """Raise :class:`ExtraMissingError` (one line naming the fix) without the ``[record]`` extra."""
    for module in ("mcap", "foxglove", "mcap_protobuf"):
        try:
            importlib.import_module(module)
        except ImportError:
            raise ExtraMissingError(
                f"this command needs the record extra ({module} is missing): "
                "pip install 'facesynth[record]'"
            ) from None
