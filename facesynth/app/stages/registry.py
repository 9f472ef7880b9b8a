"""The stages, registered like plugins: every module of :mod:`facesynth.app.stages` that exports
``STAGE`` (a :class:`~facesynth.app.stages.descriptor.StageDescriptor`) is one stage.

Adding a stage is one new module; the graph file's node types and schema, the stage commands,
their flags and the runner all read the registry. The chain's order is not written anywhere:
it follows what each stage consumes and produces, from the stage that consumes nothing.
"""

from __future__ import annotations

import difflib
import importlib
import pkgutil
from collections.abc import Iterator
from typing import Any, Union

import msgspec

from facesynth.app.stages.descriptor import StageDescriptor


class UnknownStage(ValueError):
    """A stage name no module registers; one line, naming the stages."""


class StageRegistry:
    """The stages found in ``package`` (and any registered by hand, as a test's own)."""

    def __init__(self, package: str) -> None:
        self.package = package
        self._stages: dict[str, StageDescriptor] = {}
        self._discovered = False

    def register(self, stage: StageDescriptor) -> StageDescriptor:
        """Add ``stage``; a name registered twice is an error."""
        known = self._stages.get(stage.name)
        if known is not None and known is not stage:
            raise ValueError(f"stage {stage.name!r} is registered twice")
        self._stages[stage.name] = stage
        return stage

    def unregister(self, name: str) -> None:
        """Forget a stage (tests that register their own)."""
        self._stages.pop(name, None)

    def discover(self) -> None:
        """Import the package's modules once, registering each one's ``STAGE``."""
        if self._discovered:
            return
        self._discovered = True
        package = importlib.import_module(self.package)
        for info in pkgutil.iter_modules(package.__path__, f"{self.package}."):
            stage = getattr(importlib.import_module(info.name), "STAGE", None)
            if isinstance(stage, StageDescriptor):
                self.register(stage)

    def __iter__(self) -> Iterator[StageDescriptor]:
        """The stages in chain order: the source first, then each reader of what the stages
        so far produce (by name where several read the same key), the unconnected last."""
        self.discover()
        pending = sorted(self._stages.values(), key=lambda s: s.name)
        ordered: list[StageDescriptor] = []
        produced: set[str | None] = {None}
        while pending:
            ready = [s for s in pending if s.consumes in produced]
            if not ready:
                ordered.extend(pending)
                break
            for stage in ready:
                ordered.append(stage)
                if stage.produces is not None:
                    produced.add(stage.produces)
                pending.remove(stage)
        return iter(ordered)

    def names(self) -> tuple[str, ...]:
        """Every stage's name, in chain order."""
        return tuple(stage.name for stage in self)

    def __contains__(self, name: object) -> bool:
        self.discover()
        return name in self._stages

    def get(self, name: str) -> StageDescriptor:
        """The stage called ``name``; an unknown one is a :class:`UnknownStage` naming them."""
        self.discover()
        stage = self._stages.get(name)
        if stage is None:
            close = difflib.get_close_matches(name, self._stages, n=1)
            hint = f"did you mean {close[0]}? " if close else ""
            raise UnknownStage(f"unknown stage {name!r} ({hint}stages: {', '.join(self.names())})")
        return stage

    def of(self, node: msgspec.Struct) -> StageDescriptor:
        """The stage a node runs."""
        return self.get(str(node.__struct_config__.tag))

    def node_union(self) -> Any:
        """Every stage's node struct as one tagged union (what a ``[nodes.NAME]`` table is)."""
        return Union[tuple(stage.node for stage in self)]  # noqa: UP007

    def sources(self) -> tuple[str, ...]:
        """The stages that consume nothing: the chain's input (the sensor)."""
        return tuple(stage.name for stage in self if stage.consumes is None)

    def producing(self, key: str) -> tuple[str, ...]:
        """The stages that write ``key`` (``servo_state``: the control interfaces)."""
        return tuple(stage.name for stage in self if stage.produces == key)

    def plugin_fields(self) -> tuple[str, ...]:
        """The node fields that hold plugin tables (``source``, ``backend``, ``driver``)."""
        return tuple(stage.plugin.field for stage in self if stage.plugin is not None)


#: The stages of facesynth.
STAGES = StageRegistry("facesynth.app.stages")
