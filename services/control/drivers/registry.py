"""The servo driver registry: every module of this package that registers a driver.

A driver is one module (or package) here: a config struct tagged with the driver's name
(``tag_field="driver"``) and a :class:`~services.control.drivers.base.ServoDriver` class built
as ``Driver(config, profile)``, registered with ``@DRIVERS.register(Config)``. Drivers from other
distributions register through the ``facesynth.drivers`` entry point group.
"""

from __future__ import annotations

from facesynth.runtime.plugins import Registry
from facesynth.services.control.drivers.base import ServoDriver

DRIVERS: Registry[ServoDriver] = Registry(
    "driver",
    tag_field="driver",
    package="facesynth.services.control.drivers",
    entry_points="facesynth.drivers",
)
