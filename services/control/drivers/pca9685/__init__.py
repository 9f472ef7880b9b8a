"""PCA9685 driver: the chip's registers in :mod:`.registers`, the ``pca9685`` driver (a board on
the host's own I2C bus, through smbus2) in :mod:`.driver` (registered on import)."""

from facesynth.services.control.drivers.pca9685.driver import PCA9685Config, PCA9685Driver

__all__ = ["PCA9685Config", "PCA9685Driver"]
