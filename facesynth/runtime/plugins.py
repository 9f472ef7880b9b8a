"""Plugins by registration: one registry per seam (servo drivers, points backends, frame sources).

A plugin is one module (or package) holding a msgspec config struct, tagged with the plugin's
name, and the class it configures::

    class RecordConfig(msgspec.Struct, tag="record", tag_field="driver", kw_only=True,
                       forbid_unknown_fields=True):
        out: Annotated[str, msgspec.Meta(description="JSON-lines file")]

    @DRIVERS.register(RecordConfig)
    class RecordDriver(ServoDriver): ...

Importing the module registers it. A registry finds its plugins by importing every module of its
package (so a new plugin is one new file, with no edit elsewhere) and those of an optional entry
point group (plugins shipped by other distributions). The config union, the factory, command-line
choices and help are all read from the registry, never written out by hand.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import json
import logging
import pkgutil
import tomllib
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Generic, TypeVar

import msgspec

T = TypeVar("T")
C = TypeVar("C", bound=Callable[..., Any])

log = logging.getLogger("facesynth")


class PluginError(ValueError):
    """An unknown plugin, or a plugin configuration that cannot be used; one line."""


@dataclass(frozen=True)
class Plugin(Generic[T]):
    """One registered plugin: its name (the config's tag), config struct and factory."""

    name: str
    config: type[msgspec.Struct]
    factory: Callable[..., T]
    summary: str

    def fields(self) -> tuple[msgspec.inspect.Field, ...]:
        """The config's fields, without the tag."""
        info = msgspec.inspect.type_info(self.config)
        assert isinstance(info, msgspec.inspect.StructType)
        return info.fields


class Registry(Generic[T]):
    """Plugins of one kind, keyed by the tag of their config struct.

    ``kind`` names the seam in messages ("driver"); ``tag_field`` is the key that names the
    plugin in a config mapping (``{"driver": "record", "out": "x.jsonl"}``); ``package`` is
    searched for plugin modules on first use; ``entry_points`` is an optional entry point group.
    """

    def __init__(
        self,
        kind: str,
        *,
        tag_field: str,
        package: str | None = None,
        entry_points: str | None = None,
    ) -> None:
        self.kind = kind
        self.tag_field = tag_field
        self.package = package
        self.entry_points = entry_points
        self._plugins: dict[str, Plugin[T]] = {}
        self._discovered = False

    def register(self, config: type[msgspec.Struct]) -> Callable[[C], C]:
        """Class decorator: register the decorated factory (usually a class) for ``config``."""
        struct_config = config.__struct_config__
        if struct_config.tag_field != self.tag_field or not isinstance(struct_config.tag, str):
            raise TypeError(
                f"{config.__name__} must be tagged with tag_field={self.tag_field!r} and a "
                "string tag (the plugin's name)"
            )
        name = struct_config.tag

        def decorate(factory: C) -> C:
            doc = (factory.__doc__ or config.__doc__ or "").strip()
            summary = " ".join(doc.split("\n\n")[0].split())  # the first paragraph, whole
            self._plugins[name] = Plugin(name, config, factory, summary)
            return factory

        return decorate

    def unregister(self, name: str) -> None:
        """Forget a plugin (tests that register their own)."""
        self._plugins.pop(name, None)

    def discover(self) -> None:
        """Import the package's plugin modules and the entry point group, once."""
        if self._discovered:
            return
        self._discovered = True
        if self.package is not None:
            package = importlib.import_module(self.package)
            for module in pkgutil.iter_modules(package.__path__, f"{self.package}."):
                if not module.name.rsplit(".", 1)[-1].startswith("_"):
                    importlib.import_module(module.name)
        if self.entry_points is not None:
            for entry in importlib.metadata.entry_points(group=self.entry_points):
                try:
                    entry.load()
                except Exception as exc:  # a broken third-party plugin must not stop the rest
                    log.warning("cannot load %s plugin %s: %s", self.kind, entry.name, exc)

    def names(self) -> list[str]:
        """Registered plugin names, sorted."""
        self.discover()
        return sorted(self._plugins)

    def __iter__(self) -> Iterator[Plugin[T]]:
        self.discover()
        return iter([self._plugins[name] for name in sorted(self._plugins)])

    def __contains__(self, name: object) -> bool:
        self.discover()
        return name in self._plugins

    def get(self, name: str) -> Plugin[T]:
        """The plugin called ``name``; :class:`PluginError` lists the known ones otherwise."""
        self.discover()
        try:
            return self._plugins[name]
        except KeyError:
            raise PluginError(
                f"unknown {self.kind} {name!r} (known: {', '.join(self.names())})"
            ) from None

    def parse(self, data: Mapping[str, Any], where: str = "") -> msgspec.Struct:
        """A validated config from a mapping such as ``{"driver": "record", "out": "x"}``.

        Values may be strings (command-line options): numbers and booleans are converted.
        """
        prefix = f"{where}: " if where else ""
        name = data.get(self.tag_field)
        if not isinstance(name, str):
            raise PluginError(
                f"{prefix}a {self.kind} needs {self.tag_field} = NAME "
                f"(known: {', '.join(self.names())})"
            )
        try:
            plugin = self.get(name)
        except PluginError as exc:
            raise PluginError(f"{prefix}{exc}") from None
        try:
            return msgspec.convert(dict(data), plugin.config, strict=False)
        except msgspec.ValidationError as exc:
            raise PluginError(f"{prefix}{self.kind} {name}: {exc}") from None

    def load(self, path: str | Path) -> msgspec.Struct:
        """A config from a ``.toml`` or ``.json`` file."""
        file = Path(path)
        try:
            text = file.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise PluginError(f"cannot read {self.kind} config {file}: {exc}") from None
        try:
            data = json.loads(text) if file.suffix == ".json" else tomllib.loads(text)
        except (json.JSONDecodeError, tomllib.TOMLDecodeError) as exc:
            kind = "JSON" if file.suffix == ".json" else "TOML"
            raise PluginError(f"{file}: not valid {kind}: {exc}") from None
        if not isinstance(data, dict):
            raise PluginError(f"{file}: expected a table of settings")
        return self.parse(data, str(file))

    def build(self, config: msgspec.Struct, *args: Any, **kwargs: Any) -> T:
        """The plugin object a config describes (extra arguments go to its factory)."""
        tag = config.__struct_config__.tag
        plugin = self.get(str(tag))
        if not isinstance(config, plugin.config):
            raise PluginError(f"{type(config).__name__} is not the config of {self.kind} {tag!r}")
        return plugin.factory(config, *args, **kwargs)

    def to_builtins(self, config: msgspec.Struct) -> dict[str, Any]:
        """A config as a plain mapping, tag included (for graphs and compose files)."""
        data = msgspec.to_builtins(config)
        assert isinstance(data, dict)
        return data
