"""Pololu Maestro driver: the compact protocol in :mod:`.protocol`, the ``maestro`` driver in
:mod:`.driver` (registered on import)."""

from facesynth.services.control.drivers.maestro.driver import MaestroConfig, MaestroDriver

__all__ = ["MaestroConfig", "MaestroDriver"]
