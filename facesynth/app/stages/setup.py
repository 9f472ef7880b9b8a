"""What a chain's nodes share, settled once at start: the robots' profiles (each file read once),
F's neutral window and the nodes' plugin configs (the control nodes' drivers).

:func:`facesynth.app.profile_choice.settle` makes the :class:`Setup` of a graph (which profile
each robot uses, whether its driver can show it) and every node is built from it; no node reads
another node's options or a profile file of its own.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

import msgspec

from facesynth.runtime.profiles import Profile, load_profile

#: The profile of a robot whose nodes and driver name none (:mod:`facesynth.app.profile_choice`).
DEFAULT_PROFILE = "paper16"
#: F's neutral window (seconds) when no translator's profile gives one.
DEFAULT_NEUTRAL_S = 1.0


@dataclass
class Setup:
    """The settled choices of one chain (or of one node run on its own)."""

    #: The validated plugin config of each node that has one (a control node's: its driver).
    configs: dict[str, msgspec.Struct] = field(default_factory=dict)
    #: The profile whose neutral window F uses without a calibration (None: 1 s).
    neutral_profile: str | None = None
    #: Whether the chain's input comes faster than real time (a ``--fast`` sensor).
    fast: bool = False
    #: Each profile read so far, by the name or path it was asked by.
    _profiles: dict[str, Profile] = field(default_factory=dict, repr=False)

    def loaded(self, name: str | None) -> Profile:
        """The profile ``name`` (the default when None), read on first use only."""
        key = name or DEFAULT_PROFILE
        profile = self._profiles.get(key)
        if profile is None:
            profile = self._profiles[key] = load_profile(key)
        return profile

    def profile(self, name: str | None, mirror: bool) -> Profile:
        """A node's own copy of profile ``name``, mirrored when ``mirror`` (which flips the
        profile's own)."""
        profile = copy.deepcopy(self.loaded(name))
        if mirror:
            profile.mirror = not profile.mirror
        return profile

    def neutral_seconds(self) -> float:
        """F's neutral window without a calibration: the settled profile's, else 1 s."""
        if self.neutral_profile is None:
            return DEFAULT_NEUTRAL_S
        return self.loaded(self.neutral_profile).neutral_seconds


def build_profile(name: str | None, mirror: bool) -> Profile:
    """The profile called ``name`` read now, mirrored when ``mirror``; ``None`` is the default.
    (A chain's nodes take theirs from their :class:`Setup`, read once.)"""
    return Setup().profile(name, mirror)
