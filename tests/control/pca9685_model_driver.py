"""The real ``pca9685`` driver on the register model (fake_devices/pca9685.py), registered as
driver ``pca9685-model`` so the command line (``facesynth run``, ``doctor``) can use it in this
process: the same driver class and options, only its bus seam (``open_bus``) is the model's."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

from fake_devices.pca9685 import FakeI2CAdapter

from facesynth.runtime.profiles import Profile
from facesynth.services.control.drivers.pca9685 import PCA9685Config, PCA9685Driver
from facesynth.services.control.drivers.registry import DRIVERS

NAME = "pca9685-model"


class ModelConfig(PCA9685Config, tag=NAME, tag_field="driver"):
    """The pca9685 driver's options, for the driver on the register model (tests only)."""


@contextlib.contextmanager
def model_driver(adapter: FakeI2CAdapter) -> Iterator[str]:
    """Register ``pca9685-model`` on ``adapter`` while the block runs; yields its name."""

    class ModelDriver(PCA9685Driver):
        def __init__(self, config: PCA9685Config, profile: Profile) -> None:
            super().__init__(config, profile, open_bus=adapter.open)

    DRIVERS.register(ModelConfig)(ModelDriver)
    try:
        yield NAME
    finally:
        DRIVERS.unregister(NAME)
