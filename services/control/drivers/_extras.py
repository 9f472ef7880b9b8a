"""Optional dependencies of some drivers, imported only when such a driver is built."""

from __future__ import annotations

import importlib
from types import ModuleType

from facesynth.runtime.plugins import PluginError


class MissingExtra(PluginError):
    """A driver whose optional dependency is not installed; the message names the extra."""


def require(module: str, *, plugin: str, package: str, extra: str) -> ModuleType:
    """Import ``module`` for ``plugin``, or raise :class:`MissingExtra` naming the extra."""
    try:
        return importlib.import_module(module)
    except ImportError:
        raise MissingExtra(
            f"the {plugin} needs {package}, which is not installed: "
            f"pip install 'facesynth[{extra}]'"
        ) from None
