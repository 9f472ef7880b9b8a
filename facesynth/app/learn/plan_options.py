"""The options that shape a babbling plan: chosen on the command line, kept in the session,
held to on resume.

A plan's poses depend on its kind, its seed and the options of :data:`SHAPING` (the adaptive
plan also on those of :data:`ADAPTIVE_SHAPING`). A session stores every one of them
(:meth:`PlanChoice.metadata`), so a resumed run computes the same plan: an option not given is
the session's, and one given with another value is refused with one line naming it
(:func:`choose`). A session written before they were stored names none of them: it resumes
with the defaults of that time (:data:`OLD_SESSION`, said in the log), or with the values
given, which the user then vouches for.
"""

from __future__ import annotations

import argparse
import logging
from collections.abc import Mapping
from dataclasses import dataclass, fields
from pathlib import Path

from facesynth.app.learn.adaptive import AdaptiveOptions
from facesynth.app.learn.plan import PlanError, PlanOptions

log = logging.getLogger("facesynth.learn")

#: The options that shape every plan, and their ``facesynth learn`` flags.
SHAPING = {"sweep_steps": "--sweep-steps", "neutral_every": "--neutral-every"}
#: The options that shape the adaptive plan only.
ADAPTIVE_SHAPING = {
    "region_poses": "--region-poses",
    "batch": "--batch",
    "candidates": "--candidates",
    "members": "--members",
}
#: What a session that names none of the options was babbled with: the defaults of the
#: facesynth that wrote it (kept here as they were, whatever the defaults become).
OLD_SESSION: dict[str, dict[str, int]] = {
    "fixed": {"sweep_steps": 3, "neutral_every": 25},
    # stream sessions keep their options from the first; this is there for completeness
    "stream": {"sweep_steps": 3, "neutral_every": 25},
    "adaptive": {
        "sweep_steps": 6,
        "neutral_every": 25,
        "region_poses": 250,
        "batch": 25,
        "candidates": 400,
        "members": 5,
    },
}
#: The session metadata field of option ``name`` is this prefix and the name.
FIELD_PREFIX = "learn_"
#: The largest value of each option (beyond it a plan would not fit in memory or time).
LIMITS = {
    "sweep_steps": 1000,
    "neutral_every": 1_000_000,
    "region_poses": 1_000_000,
    "batch": 10_000,
    "candidates": 100_000,
    "members": 100,
}


def shaping(kind: str) -> dict[str, str]:
    """The options that shape plan ``kind``, with their flags."""
    return {**SHAPING, **ADAPTIVE_SHAPING} if kind == "adaptive" else dict(SHAPING)


def defaults(kind: str) -> dict[str, int]:
    """The defaults of plan ``kind``'s shaping options now."""
    options = AdaptiveOptions() if kind == "adaptive" else PlanOptions()
    values = {f.name: getattr(options, f.name) for f in fields(options)}
    return {name: values[name] for name in shaping(kind)}


@dataclass(frozen=True)
class PlanChoice:
    """A plan's kind, seed and every option that shapes it."""

    kind: str
    seed: int
    values: Mapping[str, int]

    def base(self) -> PlanOptions:
        """The options of the fixed plan (the adaptive plan's sweeps are one)."""
        return PlanOptions(
            seed=self.seed,
            sweep_steps=self.values["sweep_steps"],
            neutral_every=self.values["neutral_every"],
        )

    def adaptive(self) -> AdaptiveOptions:
        """The options of the adaptive plan."""
        return AdaptiveOptions(seed=self.seed, **self.values)

    def metadata(self) -> dict[str, str]:
        """The session metadata fields that keep the options."""
        return {FIELD_PREFIX + name: str(value) for name, value in self.values.items()}

    def check(self) -> PlanChoice:
        """This choice, or :class:`PlanError` when the options cannot make a plan."""
        for name, value in self.values.items():
            if value > LIMITS[name]:
                flag = shaping(self.kind)[name]
                raise PlanError(f"{flag} {value} is too large (at most {LIMITS[name]})")
        self.base()
        if self.kind == "adaptive":
            self.adaptive()
        return self


def stored(metadata: Mapping[str, str], kind: str, path: Path) -> dict[str, int]:
    """The shaping options a session's ``metadata`` keeps (none: an older session);
    :class:`PlanError` for a value that is not a whole number."""
    values = {}
    for name, flag in shaping(kind).items():
        text = metadata.get(FIELD_PREFIX + name)
        if text is None:
            continue
        if not text.isascii() or not text.isdigit():
            raise PlanError(f"{path}: the session's {flag} {text[:20]!r} is not a whole number")
        values[name] = int(text)
    return values


def given(args: argparse.Namespace, kind: str) -> dict[str, int]:
    """The shaping options given on the command line; :class:`PlanError` for an adaptive
    plan's option given to another plan."""
    for name, flag in ADAPTIVE_SHAPING.items():
        if kind != "adaptive" and getattr(args, name, None) is not None:
            raise PlanError(f"{flag} shapes the adaptive plan only: give it with --plan adaptive")
    values = {name: getattr(args, name, None) for name in shaping(kind)}
    return {name: value for name, value in values.items() if value is not None}


def choose(
    args: argparse.Namespace,
    kind: str,
    seed: int,
    session: Mapping[str, int] | None = None,
    path: Path | None = None,
) -> PlanChoice:
    """The plan's options: those given, over the session's (``session``: the options the
    session at ``path`` keeps; ``None``: a new session) or the defaults.

    A value given that differs from the session's is a :class:`PlanError` naming the option;
    a session that keeps none resumes with :data:`OLD_SESSION` under what is given (logged).
    """
    own = given(args, kind)
    if session is None:
        return PlanChoice(kind, seed, {**defaults(kind), **own}).check()
    if not session:
        values = {**OLD_SESSION[kind], **own}
        log.info(
            "%s does not say which plan options it was babbled with (written by an older "
            "facesynth): resuming it with %s",
            path,
            ", ".join(f"{shaping(kind)[name]} {value}" for name, value in values.items()),
        )
        return PlanChoice(kind, seed, values).check()
    for name, value in own.items():
        if name in session and session[name] != value:
            flag = shaping(kind)[name]
            raise PlanError(
                f"{path} was babbled with {flag} {session[name]}: resume it with that value "
                f"(or leave {flag} out, or babble into a new file)"
            )
    return PlanChoice(kind, seed, {**OLD_SESSION[kind], **session, **own}).check()
