"""Robot profiles, by name: a TOML file per robot (``<name>.toml``), loaded and validated.

A profile lists the servos of one face: channel, limits in microseconds (min, neutral, max),
whether the servo is reversed, and what drives it, which is exactly one *source*:

* ``points = [...]``: an ``ibug68`` point group (the paper's Table 1) on ``Features.deltas``,
  with ``face_min`` / ``face_max``, the group's movement (inter-ocular units, relative to the
  neutral face) that reaches min_us / max_us when no calibration says otherwise;
* ``feature = "jaw_open"``: a named feature of :mod:`~facesynth.runtime.feature_names` (scaled by
  F: 0 neutral, ±1 the calibrated extremes), mapped ``+1 -> max_us``, ``-1 -> min_us``;
* ``blendshape = "mouthSmileLeft"``: one of the 51 ARKit blendshapes (``--model full``), which
  F publishes as named features under their own names, scaled like the others;
* ``mix = { lip_corner_pull_right = 1.0, lip_corner_depress_right = -1.0 }``: a weighted sum of
  named features (an antagonist pair on one servo), blendshapes included, then mapped as
  ``feature``.

``points`` may also accompany ``feature``, ``blendshape`` or ``mix`` as a *fallback*: it drives
the servo while the stream has not carried the named feature(s) since the translator started or
was reset (an OpenFace replay has no iris, hence no gaze). Once the feature has been seen, a
frame without it holds the servo.

Per servo, optional: ``one_sided`` (the source's negative side, e.g. a mouth more closed than
the performer's neutral, maps to ``neutral_us`` instead of toward ``min_us``: for a jaw or lips
whose neutral is closed), ``gain`` (multiplies the source value, default 1), ``deadband`` (in
source units, default 0), ``max_speed`` (µs/s) and ``max_accel`` (µs/s²) (0 = unlimited), and
``smoothing`` (overrides of the profile's One Euro parameters). Per profile, optional:
``[smoothing]`` (One Euro filter; absent or ``enabled = false`` = no filtering),
``neutral_ramp_s`` (how long a servo without ``max_speed`` takes to return to neutral when the
face is lost), ``max_command_age_s`` (the control interface drops older commands, 0.25 s by
default) and ``[[safety.exclusive]]`` rules (never two servos of a group beyond
``threshold`` of their travel at once). :data:`FORMAT_REFERENCE` is a commented example of every
field.

A *hardware profile* gives servos with channels, limits and speeds and no source: what
``facesynth learn`` and the control interface need. A *learned profile* (``NAME.learned``, one
msgpack file: :mod:`.learned_file`) is a hardware profile plus the mapping fitted on the
robot's own babbling (:mod:`.learned`, in ``Profile.learned``): T drives its servos with that
mapping; C ignores it. T refuses a profile with servos without a source unless it is learned.

Lookup order for a name: a path to an existing file; ``$FACESYNTH_PROFILES``;
``~/.config/facesynth/profiles``; the profiles shipped in this package; in each folder
``NAME.toml`` before ``NAME.learned``.

Modules: :mod:`.model` (the structs), :mod:`.loading` (lookup, parsing, :class:`ProfileError`),
:mod:`.validation` (every problem message), :mod:`.format_reference`, :mod:`.learned` (the
learned mapping and its numpy inference), :mod:`.learned_file` (its file); their public names
are importable from here.
"""

from __future__ import annotations

from .format_reference import FORMAT_REFERENCE
from .learned import Learned, describe_learned
from .learned_file import encode_learned_profile, save_learned_profile
from .loading import (
    PACKAGE_DIR,
    PROFILES,
    ProfileError,
    available_profiles,
    load_profile,
    parse_learned_profile,
    parse_profile,
    resolve_profile,
)
from .model import (
    AngleMap,
    ExclusiveRule,
    Profile,
    Safety,
    ServoSpec,
    Smoothing,
    SmoothingOverride,
    describe_source,
    has_source,
)
from .validation import validate_profile

__all__ = [
    "FORMAT_REFERENCE",
    "PACKAGE_DIR",
    "PROFILES",
    "AngleMap",
    "ExclusiveRule",
    "Learned",
    "Profile",
    "ProfileError",
    "Safety",
    "ServoSpec",
    "Smoothing",
    "SmoothingOverride",
    "available_profiles",
    "describe_learned",
    "describe_source",
    "encode_learned_profile",
    "has_source",
    "load_profile",
    "parse_learned_profile",
    "parse_profile",
    "resolve_profile",
    "save_learned_profile",
    "validate_profile",
]
