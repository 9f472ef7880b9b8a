"""The learned profile file (``NAME.learned``): one msgpack map, never pickle.

``{format: "facesynth.learned_profile", version: 3, profile: <the hardware profile, as its
TOML's fields>, inputs, reach_low, reach_high, input_mean, input_scale, outputs, dead,
inverse, forward, plan_steps, plan_prior, command_low, command_high, noise, retarget, report}``:
the fields of :class:`~.learned.Learned` at the top level, arrays as ``{dtype, shape, data:
bytes}`` (``command_low`` / ``command_high`` may be absent or None: the whole travel).
Version 2 added ``noise`` and ``retarget`` (T's retargeting into the robot's reach); a
version 1 file (neither) still loads, and T retargets it as it did. Version 3 added the
``regional`` inverse model (one model per region of the face); a version 1 or 2 file, which
cannot hold one, still loads.
:func:`encode_learned_profile` writes it;
:func:`~.loading.parse_learned_profile` reads and checks it (every malformed variant is a
:class:`~.loading.ProfileError` of one line).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import msgspec

from facesynth.runtime.atomic import write_atomic

from .learned import Learned
from .model import Profile

FORMAT = "facesynth.learned_profile"
VERSION = 3
#: The versions this reads (1: before ``noise`` and ``retarget``; 2: before ``regional``).
VERSIONS = (1, 2, 3)
#: The first version that may hold a ``regional`` inverse model.
REGIONAL_SINCE = 3
SUFFIX = ".learned"


class Header(msgspec.Struct):
    """What a file says it is (read before the rest, for a clear error)."""

    format: Any = None
    version: Any = None


class LearnedFile(Learned, forbid_unknown_fields=True, kw_only=True):
    """The whole file: the mapping's fields, plus what it is and the hardware profile."""

    format: str
    version: int
    profile: Profile


def encode_learned_profile(profile: Profile) -> bytes:
    """The file's bytes for a profile with a learned mapping."""
    if profile.learned is None:
        raise ValueError(f"profile {profile.name} has no learned mapping to write")
    hardware = msgspec.structs.replace(profile, learned=None)
    fields = msgspec.structs.asdict(profile.learned)
    document = LearnedFile(format=FORMAT, version=VERSION, profile=hardware, **fields)
    return msgspec.msgpack.encode(document)


def save_learned_profile(profile: Profile, path: str | os.PathLike[str]) -> Path:
    """Write ``profile`` (with its learned mapping) to ``path`` atomically."""
    return write_atomic(path, encode_learned_profile(profile), mode=0o644)


def split_file(document: LearnedFile) -> Profile:
    """The profile a decoded file describes, its mapping in ``learned``."""
    fields = msgspec.structs.asdict(document)
    for name in ("format", "version", "profile"):
        fields.pop(name)
    return msgspec.structs.replace(document.profile, learned=Learned(**fields))
