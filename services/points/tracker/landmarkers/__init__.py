"""Tracker models: what runs on the face crop the tracker chose, as registered plugins.

The tracker (:class:`~services.points.tracker.tracker.FaceTracker`) finds the face, chooses a
crop (from a detection, or from the previous frame's points) and decides when the face is lost.
A *tracker model* turns that crop into points: the 468-vertex face mesh and a presence score,
and what else it gives (irises, Face Landmarker v2's 478 points, blendshapes).

Each model is one module that registers itself on import with :func:`register`: its name (the
``--model`` choice), a tagged msgspec config struct (its options; the tag is the name) and a
factory. Registering is cheap: a model module imports OpenCV and its model files only when it
is built, so the CLI can list the models on a host without them.

Shipped: ``fast`` (:mod:`.fast`: the 468-point mesh plus the iris model on both eyes)
and ``full`` (:mod:`.full`: Face Landmarker v2, 478 points with the irises in one call, plus
the 52 blendshapes). :func:`tracker_models` lists them; every one of them is run through the
same contract tests (``tests/points/tracker/test_tracker_model_contract.py``).
"""

from __future__ import annotations

import importlib
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Final

import msgspec
import numpy as np

if TYPE_CHECKING:
    from ..crops import CropRect
    from ..inference import Model, ModelSpec

__all__ = [
    "BUILTIN",
    "Landmarks",
    "ModelLoader",
    "TrackerModel",
    "TrackerModelPlugin",
    "model_config",
    "model_names",
    "register",
    "tracker_models",
]

#: ``load(spec, batch)``: the tracker's model loader (backend, folder, threads and checksum
#: already chosen).
ModelLoader = Callable[["ModelSpec", int], "Model"]
#: Modules of the shipped models, imported (so registered) on first lookup.
BUILTIN: Final = ("fast", "full")


@dataclass(frozen=True, slots=True)
class Landmarks:
    """What a tracker model found besides the mesh, all in frame pixels.

    Attributes:
        iris: (10, 2) the performer's right iris centre + 4 contour points, then the left's.
        mesh478: (478, 3) Face Landmarker v2's points (mesh vertices, then both irises).
        blendshapes: (52,) scores in [0, 1] (``facesynth.runtime.blendshapes.NAMES`` order).
    """

    iris: np.ndarray | None = None
    mesh478: np.ndarray | None = None
    blendshapes: np.ndarray | None = None


class TrackerModel(ABC):
    """One tracker model, loaded. Not thread-safe (one per tracker).

    Attributes:
        name: the registered name.
        timing_keys: the extra stages it times (besides ``"mesh"``), for the tracker's timings.
    """

    name: str = ""
    timing_keys: tuple[str, ...] = ()

    @abstractmethod
    def mesh(self, frame_rgba: np.ndarray, rect: CropRect) -> tuple[np.ndarray, float]:
        """The model's points for the face in ``rect`` and its presence score in [0, 1].

        Returns (N, 3) float32 in frame pixels (z: relative depth, same scale), N >= 468; the
        first 468 are the face mesh's vertices, in MediaPipe's numbering.
        """

    @abstractmethod
    def extras(
        self, frame_rgba: np.ndarray, points: np.ndarray, timings: dict[str, float]
    ) -> Landmarks:
        """What else the model gives for a face found with :meth:`mesh`'s ``points``.

        Adds the milliseconds of each stage it runs to ``timings`` (keys: ``timing_keys``).
        """


@dataclass(frozen=True, slots=True)
class TrackerModelPlugin:
    """A registered tracker model.

    Attributes:
        name: the ``--model`` choice (also the config struct's tag).
        config: its tagged msgspec config struct (every field has a default).
        build: ``build(config, load)`` -> the loaded :class:`TrackerModel`.
        summary: one line for ``--help``.
    """

    name: str
    config: type[msgspec.Struct]
    build: Callable[[Any, ModelLoader], TrackerModel]
    summary: str


_REGISTRY: dict[str, TrackerModelPlugin] = {}


def register(plugin: TrackerModelPlugin) -> TrackerModelPlugin:
    """Register a tracker model (called by its module on import).

    Raises:
        ValueError: the name is taken by another plugin, or the config's tag differs from it.
    """
    tag = plugin.config.__struct_config__.tag
    if tag != plugin.name:
        raise ValueError(f"tracker model {plugin.name!r}: its config's tag is {tag!r}")
    existing = _REGISTRY.get(plugin.name)
    if existing is not None and existing is not plugin:
        raise ValueError(f"tracker model {plugin.name!r} is registered twice")
    _REGISTRY[plugin.name] = plugin
    return plugin


def tracker_models() -> dict[str, TrackerModelPlugin]:
    """Every registered tracker model by name (the shipped ones are imported first)."""
    for module in BUILTIN:
        importlib.import_module(f"{__name__}.{module}")
    return dict(_REGISTRY)


def model_names() -> tuple[str, ...]:
    """The ``--model`` choices."""
    return tuple(tracker_models())


def model_config(model: str | msgspec.Struct, **options: Any) -> msgspec.Struct:
    """The config struct for a model name (with ``options``), or a config given as such.

    Raises:
        ValueError: an unknown model name, or an option it does not have.
    """
    plugins = tracker_models()
    if isinstance(model, msgspec.Struct):
        tag = type(model).__struct_config__.tag
        if tag not in plugins or plugins[str(tag)].config is not type(model):
            raise ValueError(f"{type(model).__name__} is not a registered tracker model's config")
        return msgspec.structs.replace(model, **options) if options else model
    plugin = plugins.get(model)
    if plugin is None:
        raise ValueError(f"unknown tracker model {model!r}; expected one of {', '.join(plugins)}")
    try:
        config: msgspec.Struct = plugin.config(**options)
    except TypeError as exc:
        raise ValueError(f"tracker model {model!r}: {exc}") from None
    return config
