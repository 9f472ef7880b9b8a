"""The ``litert`` runtime: Google's standalone TFLite runtime (``ai_edge_litert``).

Its default XNNPACK delegate runs the models; inputs are NHWC; ``num_threads`` is honoured per
model. The fastest runtime here, so ``"auto"`` prefers it when it is installed.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import msgspec
import numpy as np

from facesynth.runtime.native_stderr import LITERT_CHATTER, chatter_to_log

from ..errors import ModelError
from ..model_files import ModelSpec
from .base import RUNTIMES, Model

_LOG = logging.getLogger(__name__)


class LiteRTRuntime(
    msgspec.Struct, tag="litert", tag_field="runtime", kw_only=True, forbid_unknown_fields=True
):
    """Google's LiteRT (``ai_edge_litert``) with XNNPACK: the fastest runtime here."""


@RUNTIMES.register(LiteRTRuntime)
class LiteRTModel(Model):
    """``ai_edge_litert`` interpreter (XNNPACK, NHWC input)."""

    requires = "ai_edge_litert"
    priority = 10

    def __init__(
        self, spec: ModelSpec, path: Path, content: bytes, batch: int, num_threads: int
    ) -> None:
        super().__init__(spec, path, content, batch, num_threads)
        from ai_edge_litert.interpreter import Interpreter

        self._content = content  # the interpreter reads from this buffer
        with chatter_to_log(_LOG, LITERT_CHATTER):  # "INFO: Created … XNNPACK delegate …"
            self._interp: Any = Interpreter(model_content=content, num_threads=num_threads)
            self._prepare(spec, batch)

    def _prepare(self, spec: ModelSpec, batch: int) -> None:
        """Check the model's input and outputs, size its input for ``batch`` and allocate."""
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
