"""Inference runtimes for the MediaPipe TFLite models, as registered plugins.

Every runtime runs the same ``.tflite`` files and returns the same outputs by name. Each is one
module of this package that registers its :class:`Model` subclass in :data:`RUNTIMES` with a
config struct tagged with its name (other distributions may add runtimes through the
``facesynth.inference_runtimes`` entry-point group), so adding a runtime is one new module:

* ``"litert"`` (:mod:`.litert`): ``ai_edge_litert`` with XNNPACK; ``num_threads`` per model.
* ``"opencv"`` (:mod:`.opencv`): OpenCV DNN's classic engine; threads are process-wide.
* ``"auto"``: the available runtime with the highest priority: ``"litert"`` when
  ``ai_edge_litert`` is importable, else ``"opencv"``.

Listing and resolving the runtimes needs neither OpenCV nor LiteRT (the command line does it on
hosts without them); a runtime imports its library when it loads a model.
"""

from __future__ import annotations

from pathlib import Path

from facesynth.runtime.plugins import PluginError

from ..errors import ModelError
from ..model_files import MODELS_DIR, ModelSpec, read_model_bytes
from .base import RUNTIMES, Model, runtime_class

__all__ = [
    "RUNTIMES",
    "Model",
    "available_backends",
    "backend_choices",
    "check_backend_name",
    "load_model",
    "resolve_backend",
    "runtime_class",
]


def backend_choices() -> tuple[str, ...]:
    """Every name a backend may be given by: ``"auto"`` and each registered runtime."""
    return ("auto", *RUNTIMES.names())


def check_backend_name(backend: str) -> str:
    """``backend`` if it is one of :func:`backend_choices` (installed or not).

    Raises:
        PluginError: an unknown name; the one-line message lists the choices.
    """
    if backend not in backend_choices():
        choices = ", ".join(backend_choices())
        raise PluginError(f"unknown backend {backend!r}; expected one of {choices}")
    return backend


def available_backends() -> tuple[str, ...]:
    """Runtimes usable in this environment (OpenCV is a hard dependency of the tracker)."""
    return tuple(name for name in RUNTIMES.names() if runtime_class(name).available())


def resolve_backend(backend: str) -> str:
    """Map ``"auto"`` to a concrete runtime and validate the name.

    Raises:
        ValueError: an unknown runtime (:class:`~facesynth.runtime.plugins.PluginError`) or
            one whose library is not installed.
    """
    if backend == "auto":
        usable = available_backends()
        if not usable:
            raise ValueError("no inference runtime is installed (install facesynth[tracker])")
        return max(usable, key=lambda name: runtime_class(name).priority)
    runtime = runtime_class(check_backend_name(backend))
    if not runtime.available():
        raise ValueError(f"backend {backend!r} requested but {runtime.requires} is not installed")
    return backend


def load_model(
    spec: ModelSpec,
    backend: str = "auto",
    *,
    model_dir: Path | str | None = None,
    num_threads: int = 1,
    batch: int = 1,
    verify: bool = True,
) -> Model:
    """Load one model file with the chosen runtime.

    Args:
        spec: which model (:data:`~services.points.tracker.model_files.DETECTOR`, ``MESH``,
            ``IRIS``, ``LANDMARKS_V2`` or ``BLENDSHAPES``).
        backend: ``"auto"`` or a runtime's name (:func:`backend_choices`).
        model_dir: folder holding ``spec.filename`` (default: the bundled ``models/``).
        num_threads: LiteRT interpreter threads (ignored by OpenCV; see :mod:`.opencv`).
        batch: images per call.
        verify: check the file's SHA-256 against ``spec.sha256``.

    Raises:
        ModelError: missing, unreadable or corrupt file, or the runtime rejects it.
        ValueError: unknown or unavailable runtime, bad ``num_threads``/``batch``.
    """
    name = resolve_backend(backend)
    if num_threads < 1 or batch < 1:
        raise ValueError("num_threads and batch must be >= 1")
    path = Path(model_dir if model_dir is not None else MODELS_DIR) / spec.filename
    content = read_model_bytes(path, spec.sha256 if verify else None)
    try:
        return runtime_class(name)(spec, path, content, batch, num_threads)
    except ModelError:
        raise
    except Exception as exc:  # runtime-specific parse errors (ValueError, RuntimeError, cv2.error)
        raise ModelError(f"cannot load model {path} with backend {name}: {exc}") from exc
