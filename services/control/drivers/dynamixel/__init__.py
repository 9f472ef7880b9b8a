"""Dynamixel driver: ROBOTIS's ``dynamixel-sdk`` on the bus thread (:mod:`.bus`), the models
and control tables (:mod:`.models`), the ``dynamixel`` driver (:mod:`.driver`, registered on
import)."""

from facesynth.services.control.drivers.dynamixel.driver import DynamixelConfig, DynamixelDriver

__all__ = ["DynamixelConfig", "DynamixelDriver"]
