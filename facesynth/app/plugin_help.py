"""Plugin listings for ``--list-drivers`` and friends, read from a registry."""

from __future__ import annotations

from typing import Any

from facesynth.app.arguments import struct_flags
from facesynth.runtime.plugins import Registry


def describe_plugins(registry: Registry[Any]) -> str:
    """One block per plugin: its name and summary, then its options with their help."""
    blocks = []
    for plugin in registry:
        lines = [f"{plugin.name}: {plugin.summary}"]
        for flag in struct_flags(plugin.config):
            default = _default(plugin.config, flag.field)
            if "default" in flag.help.lower():  # the help says it already
                default = ""
            lines.append(f"  {flag.flag:<18} {flag.help}{default}")
        blocks.append("\n".join(lines))
    return "\n".join(blocks)


def _default(config: type, field: str) -> str:
    """`` (default X)`` for a field with a default, ``" (required)"`` otherwise."""
    import msgspec

    info = msgspec.inspect.type_info(config)
    assert isinstance(info, msgspec.inspect.StructType)
    for item in info.fields:
        if item.name == field:
            if item.required:
                return " (required)"
            value = item.default if item.default is not msgspec.NODEFAULT else None
            return f" (default {value})" if value not in (None, "", False) else ""
    return ""
