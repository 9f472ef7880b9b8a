"""The profile model: a face's servos, their sources, motion limits, smoothing and safety rules.

Plain msgspec structs, as parsed from a profile's TOML (see :mod:`facesynth.runtime.profiles`
for the format); :mod:`.validation` says whether their values make sense.
"""

from __future__ import annotations

import math

import msgspec

from .learned import Learned


class Smoothing(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """One Euro filter parameters (Casiez, Roussel, Vogel, CHI 2012).

    The filter runs on each source signal in *range units*: named features as they are
    (±1 = calibrated extremes), point groups divided by half their face range, so one set of
    parameters fits both.
    """

    enabled: bool = True
    min_cutoff: float = 1.0
    beta: float = 0.0
    d_cutoff: float = 1.0


class SmoothingOverride(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """Per-servo changes to the profile's :class:`Smoothing` (unset fields keep the profile's)."""

    enabled: bool | None = None
    min_cutoff: float | None = None
    beta: float | None = None
    d_cutoff: float | None = None


class ExclusiveRule(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """At most one of ``servos`` may be beyond ``threshold`` of its travel at a time."""

    servos: list[str]
    threshold: float = 0.8


class Safety(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """Safety rules applied to the translator's output."""

    exclusive: list[ExclusiveRule] = []


class AngleMap(msgspec.Struct, forbid_unknown_fields=True, kw_only=True, frozen=True):
    """How a servo's pulse width stands for its joint angle, for outputs in angles (ROS 2).

    Linear: ``min_us`` is ``min_deg`` and ``max_us`` is ``max_deg``, extended beyond them the
    same way. The default is a hobby servo's: 500-2500 µs over 0-180°. Positions leave in
    radians (:meth:`radians`).
    """

    min_us: float = 500.0
    max_us: float = 2500.0
    min_deg: float = 0.0
    max_deg: float = 180.0

    def radians(self, us: float) -> float:
        """The joint angle in radians of a pulse of ``us`` microseconds."""
        fraction = (us - self.min_us) / (self.max_us - self.min_us)
        return math.radians(self.min_deg + fraction * (self.max_deg - self.min_deg))


class Bus(msgspec.Struct, forbid_unknown_fields=True, kw_only=True, frozen=True):
    """A smart servo bus's settings (``dynamixel``, ``feetech``): the drivers use them unless
    their own options say otherwise."""

    baud: int | None = None
    protocol: int | None = None  # Dynamixel: 1 (AX, MX) or 2 (X series); None: from the models


class ServoSpec(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """One servo: where it is wired, how far and fast it may move, what drives it."""

    name: str
    channel: int
    min_us: float
    neutral_us: float
    max_us: float
    reversed: bool = False
    points: list[int] = []
    face_min: float | None = None
    face_max: float | None = None
    feature: str | None = None
    blendshape: str | None = None
    mix: dict[str, float] | None = None
    one_sided: bool = False
    gain: float = 1.0
    deadband: float = 0.0
    max_speed: float = 0.0
    max_accel: float = 0.0
    smoothing: SmoothingOverride | None = None
    description: str = ""
    #: The pulse -> joint angle map for outputs in angles (the ``ros2`` driver).
    angle: AngleMap = msgspec.field(default_factory=AngleMap)
    #: Smart bus servos (``dynamixel``, ``feetech``): the servo's id on the bus (None: channel
    #: + 1, so channels 0..15 are ids 1..16), the model it must answer with ("XL430-W250";
    #: None: any model the driver knows) and, optionally, the native positions at min_us and
    #: max_us (both or neither; None: converted through ``angle``, 1500 µs = the centre).
    bus_id: int | None = None
    model: str | None = None
    native_min: int | None = None
    native_max: int | None = None

    def clamp(self, position: float) -> float:
        """``position`` limited to this servo's [min_us, max_us]: the last word on safety."""
        return min(max(position, self.min_us), self.max_us)

    def weights(self) -> dict[str, float] | None:
        """The named features driving this servo and their weights (None: a points servo).

        A ``blendshape`` source is the named feature of that blendshape (F publishes each of
        the 51 under its own name); a ``mix`` may weigh geometric features and blendshapes.
        """
        if self.feature is not None:
            return {self.feature: 1.0}
        if self.blendshape is not None:
            return {self.blendshape: 1.0}
        if self.mix is not None:
            return dict(self.mix)
        return None


class Profile(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """A robot or virtual face: its servos and how the performer's face maps onto them."""

    name: str
    description: str = ""
    scheme: str = "ibug68"
    mirror: bool = False
    neutral_seconds: float = 1.0
    neutral_ramp_s: float = 0.5
    max_command_age_s: float = 0.25
    smoothing: Smoothing | None = None
    safety: Safety = msgspec.field(default_factory=Safety)
    #: The smart servo bus (``[bus]``); None: the bus drivers' defaults.
    bus: Bus | None = None
    servos: list[ServoSpec]
    #: The learned mapping of a ``NAME.learned`` file (None for a TOML profile): T drives the
    #: servos with it instead of their sources; C ignores it.
    learned: Learned | None = None

    def servo(self, name: str) -> ServoSpec:
        """The servo called ``name`` (KeyError if there is none)."""
        for spec in self.servos:
            if spec.name == name:
                return spec
        raise KeyError(name)

    def neutral_positions(self) -> dict[str, float]:
        """Every servo at its neutral position."""
        return {spec.name: spec.neutral_us for spec in self.servos}

    def smoothing_for(self, spec: ServoSpec) -> Smoothing | None:
        """The One Euro parameters for ``spec``'s source, or None when it is not filtered."""
        base = self.smoothing
        if spec.smoothing is None:
            return base if base is not None and base.enabled else None
        merged = msgspec.structs.replace(base) if base is not None else Smoothing()
        for field in ("enabled", "min_cutoff", "beta", "d_cutoff"):
            value = getattr(spec.smoothing, field)
            if value is not None:
                setattr(merged, field, value)
        return merged if merged.enabled else None


def describe_source(spec: ServoSpec) -> str:
    """One line saying what drives ``spec`` (for ``facesynth profile show``)."""
    parts = []
    if spec.feature is not None:
        parts.append(f"feature {spec.feature}")
    if spec.blendshape is not None:
        parts.append(f"blendshape {spec.blendshape}")
    if spec.mix is not None:
        parts.append("mix " + ", ".join(f"{w:+g} {name}" for name, w in spec.mix.items()))
    if spec.points:
        parts.append(("fallback points " if parts else "points ") + str(spec.points))
    if spec.one_sided:
        parts.append("one-sided")
    defaults = {"gain": 1.0, "deadband": 0.0, "max_speed": 0.0, "max_accel": 0.0}
    for field, default in defaults.items():
        value = getattr(spec, field)
        if value != default:
            parts.append(f"{field} {value:g}")
    return "; ".join(parts) or "no source"


def has_source(spec: ServoSpec) -> bool:
    """Whether anything drives ``spec`` (a hardware-only servo has no source)."""
    return bool(spec.points) or spec.weights() is not None
