"""Arduino Uno servo firmware driver (the serial protocol is in :mod:`.protocol`)."""
