"""Inference backend seam for the MediaPipe TFLite models.

Two interchangeable backends run the same ``.tflite`` files and return the same outputs by
name:

* ``"litert"`` — Google's standalone TFLite runtime (``ai_edge_litert``) with its default
  XNNPACK delegate; inputs are NHWC; ``num_threads`` is honoured per model.
* ``"opencv"`` — ``cv2.dnn.readNetFromTFLite(..., engine=cv2.dnn.ENGINE_CLASSIC)`` (the new
  engine loses the detector's second output); inputs are NCHW. OpenCV's thread count is
  process-wide (``cv2.setNumThreads``) and is left to the caller.
* ``"auto"`` — ``"litert"`` when ``ai_edge_litert`` is importable, else ``"opencv"``.

Every model file is read once, its SHA-256 checked against the bundled value and the runtime is
built from those bytes, so a missing, unreadable, truncated or otherwise corrupt file raises
:class:`~services.points.tracker.errors.ModelError` instead of crashing later.
"""

from __future__ import annotations

import hashlib
import importlib.util
from abc import ABC, abstractmethod
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from .errors import ModelError

__all__ = [
    "BACKENDS",
    "BLENDSHAPES",
    "DETECTOR",
    "IRIS",
    "LANDMARKS_V2",
    "MESH",
    "MODELS_DIR",
    "Model",
    "ModelSpec",
    "available_backends",
    "fill_input",
    "frame_to_rgba",
    "load_model",
    "read_model_bytes",
    "resolve_backend",
]

BACKENDS: tuple[str, ...] = ("litert", "opencv")
MODELS_DIR: Path = Path(__file__).resolve().parent / "models"


@dataclass(frozen=True, slots=True)
class ModelSpec:
    """What the engine expects of one bundled model file.

    Image models take (batch, S, S, 3) with S = ``input_size``; a model with another input
    gives its per-item shape in ``input_shape`` (``input_size`` is then its first dimension).
    """

    filename: str
    sha256: str
    input_size: int
    outputs: tuple[str, ...]
    input_shape: tuple[int, ...] = ()

    @property
    def item_shape(self) -> tuple[int, ...]:
        """The input shape of one item (without the batch dimension)."""
        s = self.input_size
        return self.input_shape or (s, s, 3)


DETECTOR = ModelSpec(
    "face_detection_short_range.tflite",
    "bbff11cebd1eb27a1e004cae0b0e63ec8c551cbf34a4451148b4908b8db3eca8",
    128,
    ("regressors", "classificators"),
)
MESH = ModelSpec(
    "face_landmark.tflite",
    "1055cb9d4a9ca8b8c688902a3a5194311138ba256bcc94e336d8373a5f30c814",
    192,
    ("conv2d_21", "conv2d_31"),
)
IRIS = ModelSpec(
    "iris_landmark.tflite",
    "d1744d2a09c25f501d39eba4faff47e53ecca8852c5ce19bce8eeac39357521f",
    64,
    ("output_iris", "output_eyes_contours_and_brows"),
)
#: Face Landmarker v2 (``face_landmarks_detector.tflite`` from ``face_landmarker.task``): 478
#: points (x, y, z in input pixels), presence logit; ``Identity_2`` is not used.
LANDMARKS_V2 = ModelSpec(
    "face_landmarks_detector.tflite",
    "c7d54204ce0448474c7f3fa9af494787c0965cbdd6f20fc72867e43046bd43d5",
    256,
    ("Identity", "Identity_1"),
)
#: The 52 ARKit-style blendshape scores from 146 of the 478 points (x, y in frame pixels).
BLENDSHAPES = ModelSpec(
    "face_blendshapes.tflite",
    "4f36dded049db18d76048567439b2a7f58f1daabc00d78bfe8f3ad396a2d2082",
    146,
    ("StatefulPartitionedCall:0",),
    input_shape=(146, 2),
)


def _litert_importable() -> bool:
    try:
        return importlib.util.find_spec("ai_edge_litert.interpreter") is not None
    except (ImportError, ValueError):
        return False


def available_backends() -> tuple[str, ...]:
    """Backends usable in this environment (OpenCV is a hard dependency of the tracker)."""
    return ("litert", "opencv") if _litert_importable() else ("opencv",)


def resolve_backend(backend: str) -> str:
    """Map ``"auto"`` to a concrete backend and validate the name."""
    if backend == "auto":
        return "litert" if _litert_importable() else "opencv"
    if backend not in BACKENDS:
        choices = ", ".join(("auto", *BACKENDS))
        raise ValueError(f"unknown backend {backend!r}; expected one of {choices}")
    if backend == "litert" and not _litert_importable():
        raise ValueError("backend 'litert' requested but ai_edge_litert is not installed")
    return backend


def read_model_bytes(path: Path | str, expected_sha256: str | None) -> bytes:
    """Read a model file and check its SHA-256 (skipped when ``expected_sha256`` is None).

    Raises:
        ModelError: the file is missing, unreadable, empty or has the wrong checksum.
    """
    p = Path(path)
    try:
        data = p.read_bytes()
    except FileNotFoundError as exc:
        raise ModelError(f"model file not found: {p}") from exc
    except OSError as exc:
        raise ModelError(f"model file unreadable: {p}: {exc}") from exc
    if not data:
        raise ModelError(f"model file is empty: {p}")
    if expected_sha256 is not None:
        digest = hashlib.sha256(data).hexdigest()
        if digest != expected_sha256:
            raise ModelError(
                f"model file corrupt: {p} ({len(data)} bytes) has sha256 {digest}, "
                f"expected {expected_sha256} (see models/PROVENANCE.md)"
            )
    return data


def frame_to_rgba(image: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """Convert a uint8 BGR (H, W, 3), BGRA (H, W, 4) or grey (H, W) frame to RGBA.

    Four-channel images are what ``cv2.warpAffine`` resamples fastest. ``out`` is reused when
    it has the right shape.

    Raises:
        ValueError: not a uint8 image of one of those shapes, or empty.
    """
    if not isinstance(image, np.ndarray) or image.dtype != np.uint8:
        raise ValueError("expected a uint8 numpy image")
    if image.ndim == 2:
        code = cv2.COLOR_GRAY2RGBA
    elif image.ndim == 3 and image.shape[2] == 3:
        code = cv2.COLOR_BGR2RGBA
    elif image.ndim == 3 and image.shape[2] == 4:
        code = cv2.COLOR_BGRA2RGBA
    else:
        raise ValueError(f"expected an (H, W), (H, W, 3) or (H, W, 4) image, got {image.shape}")
    h, w = image.shape[:2]
    if h < 1 or w < 1:
        raise ValueError("empty image")
    if out is None or out.shape != (h, w, 4):
        out = np.empty((h, w, 4), np.uint8)
    cv2.cvtColor(image, code, dst=out)
    return out


def fill_input(
    dst: np.ndarray, crop_rgba: np.ndarray, scale: float, offset: float, scratch: np.ndarray
) -> None:
    """Write ``rgb * scale + offset`` of a uint8 RGBA crop into a float32 (S, S, 3) view.

    ``scratch`` is a uint8 (S, S, 3) buffer reused for the RGBA -> RGB step.
    """
    cv2.cvtColor(crop_rgba, cv2.COLOR_RGBA2RGB, dst=scratch)
    np.multiply(scratch, np.float32(scale), out=dst)
    if offset:
        np.add(dst, np.float32(offset), out=dst)


class Model(ABC):
    """A loaded model with a preallocated NHWC float32 input.

    Fill :meth:`input_view` (shape (batch, S, S, 3), RGB, already scaled; (batch,
    *spec.input_shape) for a non-image model) and call :meth:`run`.

    Attributes:
        backend: ``"litert"`` or ``"opencv"``.
        spec: the :class:`ModelSpec` it was loaded for.
        batch: images per call.
        input_size: S.
    """

    backend: str

    def __init__(self, spec: ModelSpec, batch: int) -> None:
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


class LiteRTModel(Model):
    """``ai_edge_litert`` interpreter (XNNPACK, NHWC input)."""

    backend = "litert"

    def __init__(self, spec: ModelSpec, content: bytes, batch: int, num_threads: int) -> None:
        super().__init__(spec, batch)
        from ai_edge_litert.interpreter import Interpreter

        self._content = content  # the interpreter reads from this buffer
        self._interp: Any = Interpreter(model_content=content, num_threads=num_threads)
        inputs = self._interp.get_input_details()
        if len(inputs) != 1:
            raise ModelError(f"{spec.filename}: expected one input, found {len(inputs)}")
        self._in_idx = int(inputs[0]["index"])
        item = list(spec.item_shape)
        if list(inputs[0]["shape"]) != [1, *item]:
            raise ModelError(
                f"{spec.filename}: input shape {list(inputs[0]['shape'])}, expected {[1, *item]}"
            )
        if batch != 1:
            self._interp.resize_tensor_input(self._in_idx, [batch, *item])
        self._interp.allocate_tensors()
        by_name = {d["name"]: int(d["index"]) for d in self._interp.get_output_details()}
        missing = [n for n in spec.outputs if n not in by_name]
        if missing:
            raise ModelError(f"{spec.filename}: outputs {missing} not found in {sorted(by_name)}")
        self._out_idx = [(n, by_name[n]) for n in spec.outputs]
        self._view = self._interp.tensor(self._in_idx)
        self.input_view()[...] = 0.0

    def input_view(self) -> np.ndarray:
        """See :meth:`Model.input_view`."""
        view: np.ndarray = self._view()
        return view

    def run(self) -> dict[str, np.ndarray]:
        """See :meth:`Model.run`."""
        self._interp.invoke()
        return {n: self._interp.get_tensor(idx).reshape(self.batch, -1) for n, idx in self._out_idx}


class OpenCVModel(Model):
    """OpenCV DNN classic engine (NCHW input)."""

    backend = "opencv"

    def __init__(self, spec: ModelSpec, path: Path, batch: int) -> None:
        super().__init__(spec, batch)
        # Load by path: in OpenCV 5.0 the in-memory overload ignores ``engine`` and the new
        # engine drops the detector's ``classificators`` output.
        self._net = cv2.dnn.readNetFromTFLite(str(path), engine=cv2.dnn.ENGINE_CLASSIC)
        names = tuple(self._net.getUnconnectedOutLayersNames())
        missing = [n for n in spec.outputs if n not in names]
        if missing:
            raise ModelError(f"{spec.filename}: outputs {missing} not found in {sorted(names)}")
        self._names = list(spec.outputs)
        self._input = np.zeros((batch, *spec.item_shape), np.float32)
        self._image = len(spec.item_shape) == 3
        s = spec.input_size
        self._nchw = np.zeros((batch, 3, s, s), np.float32) if self._image else self._input
        # Fail now, not on the first frame, if the graph does not accept the input shape.
        self.run()

    def input_view(self) -> np.ndarray:
        """See :meth:`Model.input_view`."""
        return self._input

    def run(self) -> dict[str, np.ndarray]:
        """See :meth:`Model.run`."""
        if self._image:
            np.copyto(self._nchw, self._input.transpose(0, 3, 1, 2))
        self._net.setInput(self._nchw)
        outs = self._net.forward(self._names)
        return {
            n: np.asarray(o, dtype=np.float32).reshape(self.batch, -1)
            for n, o in zip(self._names, outs, strict=True)
        }


def load_model(
    spec: ModelSpec,
    backend: str = "auto",
    *,
    model_dir: Path | str | None = None,
    num_threads: int = 1,
    batch: int = 1,
    verify: bool = True,
) -> Model:
    """Load one model file with the chosen backend.

    Args:
        spec: which model (:data:`DETECTOR`, :data:`MESH`, :data:`IRIS`, :data:`LANDMARKS_V2`
            or :data:`BLENDSHAPES`).
        backend: ``"auto"``, ``"litert"`` or ``"opencv"``.
        model_dir: folder holding ``spec.filename`` (default: the bundled ``models/``).
        num_threads: LiteRT interpreter threads (ignored by OpenCV; see module docstring).
        batch: images per call.
        verify: check the file's SHA-256 against ``spec.sha256``.

    Raises:
        ModelError: missing, unreadable or corrupt file, or the runtime rejects it.
        ValueError: unknown or unavailable backend, bad ``num_threads``/``batch``.
    """
    name = resolve_backend(backend)
    if num_threads < 1 or batch < 1:
        raise ValueError("num_threads and batch must be >= 1")
    path = Path(model_dir if model_dir is not None else MODELS_DIR) / spec.filename
    content = read_model_bytes(path, spec.sha256 if verify else None)
    try:
        if name == "litert":
            return LiteRTModel(spec, content, batch, num_threads)
        return OpenCVModel(spec, path, batch)
    except ModelError:
        raise
    except Exception as exc:  # runtime-specific parse errors (ValueError, RuntimeError, cv2.error)
        raise ModelError(f"cannot load model {path} with backend {name}: {exc}") from exc
