"""The inference-runtime seam: a loaded model, and the registry of the runtimes that load them."""

from __future__ import annotations

import importlib.util
from abc import ABC, abstractmethod
from pathlib import Path
from typing import ClassVar

import numpy as np

from facesynth.runtime.plugins import Registry

from ..model_files import ModelSpec

__all__ = ["RUNTIMES", "Model", "runtime_class"]


class Model(ABC):
    """A model loaded by one inference runtime, with a preallocated NHWC float32 input.

    Fill :meth:`input_view` (shape (batch, S, S, 3), RGB, already scaled; (batch,
    *spec.input_shape) for a non-image model) and call :meth:`run`.

    A runtime is a subclass registered in :data:`RUNTIMES` with an empty config struct tagged
    with the runtime's name (``tag_field="runtime"``), in a module of its own in this package; it
    imports its library only when it loads a model, so that the runtimes can be listed where the
    library is absent.

    Attributes:
        spec: the :class:`~services.points.tracker.model_files.ModelSpec` it was loaded for.
        batch: images per call.
        input_size: S.
    """

    #: The top-level module the runtime needs: without it the runtime is unavailable.
    requires: ClassVar[str]
    #: ``"auto"`` picks the available runtime with the highest priority.
    priority: ClassVar[int] = 0

    @classmethod
    def available(cls) -> bool:
        """Whether this runtime can load models here (:attr:`requires` is importable)."""
        try:
            return importlib.util.find_spec(cls.requires) is not None
        except (ImportError, ValueError):
            return False

    def __init__(
        self, spec: ModelSpec, path: Path, content: bytes, batch: int, num_threads: int
    ) -> None:
        """Load ``spec`` from the file ``path`` whose checked bytes are ``content``.

        ``num_threads`` is the runtime's thread count for this model, where it has one per model.

        Raises:
            ModelError: the model does not have the input or outputs ``spec`` names; any other
                exception of the runtime is wrapped in a ``ModelError`` by the caller.
        """
        self.spec = spec
        self.batch = batch
        self.input_size = spec.input_size

    @abstractmethod
    def input_view(self) -> np.ndarray:
        """The (batch, S, S, 3) float32 input to fill in place before :meth:`run`.

        With LiteRT this is the interpreter's own tensor memory (no copy on run); do not keep
        the array across :meth:`run` — the interpreter refuses to run while it is referenced.
        """

    @abstractmethod
    def run(self) -> dict[str, np.ndarray]:
        """Run on the filled :meth:`input_view`.

        Returns every output named in ``spec.outputs`` as a float32 array of shape (batch, n),
        n the flattened per-image output size.
        """


#: The inference runtimes by name: the modules of this package, and the entry points of the
#: ``facesynth.inference_runtimes`` group (other distributions' runtimes).
RUNTIMES: Registry[Model] = Registry(
    "inference runtime",
    tag_field="runtime",
    package=__name__.rpartition(".")[0],
    entry_points="facesynth.inference_runtimes",
)


def runtime_class(name: str) -> type[Model]:
    """The :class:`Model` subclass of the runtime called ``name`` (PluginError if none)."""
    factory = RUNTIMES.get(name).factory
    if not (isinstance(factory, type) and issubclass(factory, Model)):
        raise TypeError(f"inference runtime {name!r} is not a Model subclass")
    return factory
