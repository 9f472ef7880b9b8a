"""TOML text for the files facesynth writes itself (graphs, the console's profiles).

:func:`toml_value` writes one value; each writer keeps its own layout (tables, which keys it
leaves out), so its files read back as they did.
"""

from __future__ import annotations

from typing import Any

import msgspec


def toml_value(value: Any, *, bare_keys: bool = False, skip_none: bool = False) -> str:
    """One TOML value: strings, numbers, booleans, lists and inline tables.

    An inline table's keys are quoted strings unless ``bare_keys`` (then written as they are:
    the caller's keys are names); with ``skip_none`` its ``None`` entries are left out, else a
    ``None`` anywhere is a ``TypeError``, as any other value TOML cannot hold."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return msgspec.json.encode(value).decode()
    if isinstance(value, int | float):
        return repr(value)
    if isinstance(value, list):
        items = (toml_value(v, bare_keys=bare_keys, skip_none=skip_none) for v in value)
        return "[" + ", ".join(items) + "]"
    if isinstance(value, dict):
        pairs = [
            f"{k if bare_keys else toml_value(str(k))} = "
            f"{toml_value(v, bare_keys=bare_keys, skip_none=skip_none)}"
            for k, v in value.items()
            if not (skip_none and v is None)
        ]
        return "{ " + ", ".join(pairs) + " }"
    raise TypeError(f"cannot write {value!r} as TOML")
