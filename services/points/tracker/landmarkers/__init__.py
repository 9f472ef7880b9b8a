"""Tracker models: what runs on the face crop the tracker chose, as registered plugins.

The tracker (:class:`~services.points.tracker.tracker.FaceTracker`) finds the face, chooses a
crop (from a detection, or from the previous frame's points) and decides when the face is lost.
A *tracker model* turns that crop into points: the 468-vertex face mesh and a presence score,
and what else it gives (irises, Face Landmarker v2's 478 points, blendshapes).

Each model is one module of this package that registers itself on import in
:data:`TRACKER_MODELS` (a :class:`facesynth.runtime.plugins.Registry`): a msgspec config struct
tagged with the model's name (``tag_field="model"``; its fields are the model's options) and
the :class:`TrackerModel` class, built as ``Model(config, load)``. Registering is cheap: a model
module imports OpenCV and its model files only when it is built, so the CLI can list the models
on a host without them.

Shipped: ``fast`` (:mod:`.fast`: the 468-point mesh plus the iris model on both eyes)
and ``full`` (:mod:`.full`: Face Landmarker v2, 478 points with the irises in one call, plus
the 52 blendshapes). Every registered model is run through the same contract tests
(``tests/points/tracker/test_tracker_model_contract.py``).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import msgspec
import numpy as np

from facesynth.runtime.plugins import PluginError, Registry

if TYPE_CHECKING:
    from ..crops import CropRect
    from ..model_files import ModelSpec
    from ..runtimes import Model

__all__ = [
    "TRACKER_MODELS",
    "Landmarks",
    "ModelLoader",
    "TrackerModel",
    "model_config",
    "model_names",
]

#: ``load(spec, batch)``: the tracker's model loader (backend, folder, threads and checksum
#: already chosen).
ModelLoader = Callable[["ModelSpec", int], "Model"]


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
    """One tracker model, loaded: ``Model(config, load)``. Not thread-safe (one per tracker).

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


TRACKER_MODELS: Registry[TrackerModel] = Registry(
    "tracker model", tag_field="model", package=__name__, entry_points="facesynth.tracker_models"
)


def model_names() -> list[str]:
    """The registered tracker models (the ``--model`` choices), sorted."""
    return TRACKER_MODELS.names()


def model_config(model: str | msgspec.Struct, **options: Any) -> msgspec.Struct:
    """The config struct for a model name (with ``options``), or a config given as such.

    Raises:
        PluginError: an unknown model name, an option it does not have or a bad value.
    """
    if isinstance(model, msgspec.Struct):
        tag = type(model).__struct_config__.tag
        plugin = TRACKER_MODELS.get(str(tag))
        if plugin.config is not type(model):
            raise PluginError(f"{type(model).__name__} is not the config of tracker model {tag!r}")
        return msgspec.structs.replace(model, **options) if options else model
    return TRACKER_MODELS.parse({"model": model, **options})
