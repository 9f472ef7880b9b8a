"""Typed driver configurations (a msgspec tagged union) and the factory that builds drivers.

A configuration comes from the command line (``--driver record --out FILE``) or from a TOML or
JSON file (``--driver-config FILE``) such as ``driver = "record"`` + ``out = "commands.jsonl"``.
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import msgspec

from services.control.drivers.base import ServoDriver
from services.control.drivers.record import RecordDriver


class DriverConfigError(ValueError):
    """A driver configuration that cannot be used."""


class RecordConfig(msgspec.Struct, tag="record", tag_field="driver", forbid_unknown_fields=True):
    """Record every command to a JSON-lines file."""

    out: str


DriverConfig = RecordConfig
DRIVERS = ("record",)


def parse_driver_config(data: dict[str, object], source: str = "<driver config>") -> DriverConfig:
    """Validate a driver configuration mapping."""
    try:
        return msgspec.convert(data, DriverConfig)
    except msgspec.ValidationError as exc:
        raise DriverConfigError(f"{source}: {exc} (drivers: {', '.join(DRIVERS)})") from None


def load_driver_config(path: str | Path) -> DriverConfig:
    """Load a driver configuration from a ``.toml`` or ``.json`` file."""
    file = Path(path)
    try:
        text = file.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise DriverConfigError(f"cannot read driver config {file}: {exc}") from None
    try:
        data = json.loads(text) if file.suffix == ".json" else tomllib.loads(text)
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as exc:
        raise DriverConfigError(f"{file}: not valid {file.suffix[1:] or 'TOML'}: {exc}") from None
    if not isinstance(data, dict):
        raise DriverConfigError(f"{file}: expected a table of settings")
    return parse_driver_config(data, str(file))


def make_driver(config: DriverConfig) -> ServoDriver:
    """The driver a configuration describes."""
    if isinstance(config, RecordConfig):
        return RecordDriver(config.out)
    raise DriverConfigError(f"no driver for {config!r}")
