"""Arduino Uno servo firmware driver: the serial protocol is in :mod:`.protocol` (standard
library only), the ``arduino`` driver in :mod:`.driver` (registered on import)."""

from facesynth.services.control.drivers.arduino.driver import ArduinoConfig, ArduinoDriver

__all__ = ["ArduinoConfig", "ArduinoDriver"]
