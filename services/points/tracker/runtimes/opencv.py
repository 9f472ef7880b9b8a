"""The ``opencv`` runtime: OpenCV DNN's classic engine (``cv2.dnn.readNetFromTFLite``).

The classic engine, because the new one loses the detector's second output; inputs are NCHW.
OpenCV's thread count is process-wide (``cv2.setNumThreads``) and is left to the caller, so
``num_threads`` is ignored. Always available with the tracker (OpenCV is its hard dependency).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import msgspec
import numpy as np

from ..errors import ModelError
from ..model_files import ModelSpec
from .base import RUNTIMES, Model


class OpenCVRuntime(
    msgspec.Struct, tag="opencv", tag_field="runtime", kw_only=True, forbid_unknown_fields=True
):
    """OpenCV DNN's classic engine: always there with the tracker."""


@RUNTIMES.register(OpenCVRuntime)
class OpenCVModel(Model):
    """OpenCV DNN classic engine (NCHW input)."""

    requires = "cv2"

    def __init__(
        self, spec: ModelSpec, path: Path, content: bytes, batch: int, num_threads: int
    ) -> None:
        super().__init__(spec, path, content, batch, num_threads)
        import cv2

        # Load by path: in OpenCV 5.0 the in-memory overload ignores ``engine`` and the new
        # engine drops the detector's ``classificators`` output.
        self._net: Any = cv2.dnn.readNetFromTFLite(str(path), engine=cv2.dnn.ENGINE_CLASSIC)
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
        if self._image:  # NHWC -> NCHW; other inputs go as they are
            np.copyto(self._nchw, self._input.transpose(0, 3, 1, 2))
        self._net.setInput(self._nchw)
        outs = self._net.forward(self._names)
        return {
            n: np.asarray(o, dtype=np.float32).reshape(self.batch, -1)
            for n, o in zip(self._names, outs, strict=True)
        }
