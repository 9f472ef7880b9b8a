"""Lynxmotion SSC-32 driver: the ASCII protocol in :mod:`.protocol`, the ``ssc32`` driver in
:mod:`.driver` (registered on import)."""

from facesynth.services.control.drivers.ssc32.driver import SSC32Config, SSC32Driver

__all__ = ["SSC32Config", "SSC32Driver"]
