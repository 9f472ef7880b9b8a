"""What a closed loop learned, kept beside its learned profile (``NAME.loop`` next to
``NAME.learned``): one msgpack map, never pickle.

``{format: "facesynth.closed_loop", version: 1, profile, inputs, outputs, weights,
covariance, updates}``: ``weights`` (inputs, outputs + 1) and ``covariance`` (outputs + 1,
outputs + 1) are :class:`~facesynth.services.translator.closed_loop.LoopState`'s arrays as
``{dtype, shape, data}`` (:class:`~facesynth.runtime.profiles.learned.ArrayData`); ``inputs``
and ``outputs`` name the features and servos they are about, so a state is never applied to
another profile's models. :func:`save_loop_state` writes it atomically; :func:`load_loop_state`
reads and checks it, every malformed variant a :class:`LoopStateError` of one line.
"""

from __future__ import annotations

import os
from pathlib import Path

import msgspec
import numpy as np

from facesynth.runtime.atomic import write_atomic
from facesynth.runtime.oneline import one_line
from facesynth.runtime.profiles.learned import ArrayData, Learned, array_problem, pack, unpack
from facesynth.services.translator.closed_loop import LoopState

__all__ = ["FORMAT", "SUFFIX", "LoopStateError", "load_loop_state", "loop_state_path"]

FORMAT = "facesynth.closed_loop"
VERSION = 1
SUFFIX = ".loop"
#: The largest magnitude a state's value may have (a loop's corrections are of the order of
#: the robot's own spread of a feature, 1, and its covariance at most its prior).
LARGEST = 1e6


class LoopStateError(ValueError):
    """A closed loop's state file that cannot be used; one line."""


class LoopFile(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """The file's fields (see the module's docstring)."""

    format: str
    version: int
    profile: str
    inputs: list[str]
    outputs: list[str]
    weights: ArrayData
    covariance: ArrayData
    updates: int


def loop_state_path(profile_path: str | os.PathLike[str]) -> Path:
    """Where the loop state of the learned profile at ``profile_path`` is kept: beside it,
    ``NAME.loop``."""
    return Path(profile_path).with_suffix(SUFFIX)


def encode_loop_state(state: LoopState, name: str, learned: Learned) -> bytes:
    """The file's bytes for ``state``, learned on profile ``name`` with mapping ``learned``."""
    document = LoopFile(
        format=FORMAT,
        version=VERSION,
        profile=name,
        inputs=list(learned.inputs),
        outputs=list(learned.outputs),
        weights=pack(state.weights),
        covariance=pack(state.covariance),
        updates=state.updates,
    )
    return msgspec.msgpack.encode(document)


def save_loop_state(
    state: LoopState, name: str, learned: Learned, path: str | os.PathLike[str]
) -> Path:
    """Write ``state`` to ``path`` atomically (a reader sees the old file or the new one)."""
    return write_atomic(path, encode_loop_state(state, name, learned), mode=0o644)


def decode_loop_state(data: bytes, learned: Learned) -> LoopState:
    """The state in ``data`` for the mapping ``learned``; :class:`LoopStateError` (without
    the file's name) when it is malformed or about another profile's models."""
    try:
        document = msgspec.msgpack.decode(data, type=LoopFile)
    except (msgspec.DecodeError, msgspec.ValidationError, UnicodeDecodeError) as exc:
        raise LoopStateError(f"not a closed-loop state file ({one_line(str(exc))})") from None
    if document.format != FORMAT:
        raise LoopStateError(f"format {document.format!r} is not {FORMAT!r}")
    if document.version != VERSION:
        raise LoopStateError(f"version {document.version} is not supported (this reads 1)")
    if document.inputs != list(learned.inputs) or document.outputs != list(learned.outputs):
        raise LoopStateError(
            f"it was learned for other models (profile {document.profile!r}: its inputs or "
            "outputs differ from this profile's); remove it to start afresh"
        )
    n_in, n_out = len(learned.inputs), len(learned.outputs)
    shapes = {"weights": [n_in, n_out + 1], "covariance": [n_out + 1, n_out + 1]}
    for name, shape in shapes.items():
        array = getattr(document, name)
        problem = array_problem(array)
        if problem is None and array.shape != shape:
            problem = f"shape {array.shape} is not {shape}"
        if problem is not None:
            raise LoopStateError(f"{name}: {problem}")
        if np.abs(unpack(array)).max(initial=0.0) > LARGEST:
            raise LoopStateError(f"{name}: holds values beyond ±{LARGEST:g}")
    covariance = unpack(document.covariance)
    if not np.allclose(covariance, covariance.T) or np.any(np.diag(covariance) < 0):
        raise LoopStateError("covariance is not symmetric with a diagonal >= 0")
    if document.updates < 0:
        raise LoopStateError(f"updates {document.updates} is negative")
    return LoopState(
        weights=unpack(document.weights), covariance=covariance, updates=document.updates
    )


def load_loop_state(path: str | os.PathLike[str], learned: Learned) -> LoopState | None:
    """The state kept at ``path`` for the mapping ``learned`` (None: no file there yet);
    :class:`LoopStateError` naming the file when it cannot be used."""
    try:
        data = Path(path).read_bytes()
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise LoopStateError(f"loop state {path}: {exc.strerror or exc}") from None
    try:
        return decode_loop_state(data, learned)
    except LoopStateError as exc:
        raise LoopStateError(f"loop state {path}: {exc}") from None
