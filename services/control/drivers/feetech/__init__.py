"""Feetech driver: Feetech's ``scservo_sdk`` (feetech-servo-sdk) on the bus thread
(:mod:`.bus`), the models and memory tables (:mod:`.models`), the ``feetech`` driver
(:mod:`.driver`, registered on import)."""

from facesynth.services.control.drivers.feetech.driver import FeetechConfig, FeetechDriver

__all__ = ["FeetechConfig", "FeetechDriver"]
