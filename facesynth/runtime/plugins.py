"""Plugins by name: implementations of one seam that register themselves when imported.

A seam with several implementations (servo drivers, points backends, inference runtimes) keeps
one :class:`Registry`. Each implementation lives in a module of its own and adds itself with the
:meth:`Registry.register` decorator; the registry finds those modules by itself on its first
lookup, by importing every module of its ``package`` and loading every entry point of its
``group`` (for plugins shipped in other distributions). Adding an implementation is therefore one
new module, with no list to edit elsewhere; command-line choices and error messages come from
:meth:`Registry.names`.

Example::

    RUNTIMES: Registry[type[Model]] = Registry(
        "inference runtime", package=__name__, group="facesynth.inference_runtimes"
    )

    @RUNTIMES.register("opencv")  # in a module of that package
    class OpenCVModel(Model): ...

    RUNTIMES.get("opencv")  # -> OpenCVModel; an unknown name raises UnknownPluginError
"""

from __future__ import annotations

import importlib
import importlib.metadata
import pkgutil
from collections.abc import Callable
from typing import Generic, TypeVar

__all__ = ["Registry", "UnknownPluginError"]

T = TypeVar("T")


class UnknownPluginError(ValueError):
    """A name no plugin of the registry's kind is registered under (the message lists them)."""


class Registry(Generic[T]):
    """Plugins of one kind, by name (a name -> plugin mapping filled by decorators).

    Args:
        kind: what the plugins are, for messages (``"servo driver"``).
        package: dotted name of a package whose modules are all imported before the first
            lookup, so that each registers itself (None: no package to scan).
        group: an entry-point group (``"facesynth.inference_runtimes"``) whose entry points are
            loaded before the first lookup; each names a module, or an object in one, that
            registers its plugins when imported (None: no entry points).
    """

    def __init__(self, kind: str, *, package: str | None = None, group: str | None = None) -> None:
        self.kind = kind
        self.package = package
        self.group = group
        self._plugins: dict[str, T] = {}
        self._discovered = package is None and group is None

    def register(self, name: str) -> Callable[[T], T]:
        """A decorator adding the decorated class or function under ``name``.

        Raises:
            ValueError: ``name`` is empty or holds white space, or another plugin has it.
        """

        def add(plugin: T) -> T:
            if not name or name != "".join(name.split()):
                raise ValueError(f"{self.kind} name {name!r} is empty or holds white space")
            known = self._plugins.get(name)
            if known is not None and known is not plugin:
                raise ValueError(f"{self.kind} {name!r} is registered twice")
            self._plugins[name] = plugin
            return plugin

        return add

    def names(self) -> tuple[str, ...]:
        """Every registered name, sorted."""
        self._discover()
        return tuple(sorted(self._plugins))

    def get(self, name: str) -> T:
        """The plugin registered under ``name``.

        Raises:
            UnknownPluginError: no plugin has that name; the one-line message lists the names.
        """
        self._discover()
        try:
            return self._plugins[name]
        except KeyError:
            known = ", ".join(self.names()) or "(none)"
            raise UnknownPluginError(
                f"unknown {self.kind} {name!r}; expected one of {known}"
            ) from None

    def __contains__(self, name: object) -> bool:
        self._discover()
        return name in self._plugins

    def _discover(self) -> None:
        """Import the package's modules and the group's entry points, once."""
        if self._discovered:
            return
        self._discovered = True  # plugin modules may look names up while being imported
        try:
            if self.package is not None:
                package = importlib.import_module(self.package)
                for module in pkgutil.iter_modules(package.__path__, f"{self.package}."):
                    importlib.import_module(module.name)
            if self.group is not None:
                for entry_point in importlib.metadata.entry_points(group=self.group):
                    entry_point.load()
        except BaseException:
            self._discovered = False  # a broken plugin fails every lookup, not only the first
            raise
