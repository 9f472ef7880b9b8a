"""The ``vmc`` driver: blendshapes and head pose to avatar software, over the VMC protocol.

VMC (Virtual Motion Capture protocol, https://protocol.vmc.info) is OSC over UDP. facesynth is
a *Performer* sending to a *Marionette* (the avatar app, usually listening on port 39539). Per
command, one OSC bundle holds:

* ``/VMC/Ext/Blend/Val (string){name} (float){value}`` for every blendshape (0..1), then
  ``/VMC/Ext/Blend/Apply`` (the receiver applies them together);
* ``/VMC/Ext/Bone/Pos (string)"Head" p.x p.y p.z q.x q.y q.z q.w`` when the profile has head
  pose controls (below);
* ``/VMC/Ext/OK (int)1`` and ``/VMC/Ext/T (float){seconds since connect}``.

Which blendshapes, from the profile's controls (values in the profile's units):

1. a control named after an ARKit blendshape (``jawOpen``, ``eyeBlinkLeft``, …; an ``arkit52``
   style profile, one control per blendshape, 0..1000) sends ``value / 1000``;
2. a control of the ``virtual`` profile maps through :data:`VIRTUAL_TO_ARKIT`: its travel from
   neutral toward max (or toward min) is 0..1 of one ARKit blendshape, e.g. ``lid_left`` above
   neutral is ``eyeWideLeft``, below it ``eyeBlinkLeft``; ``browInnerUp`` is the mean raise of
   both brows;
3. ``head_yaw``, ``head_pitch``, ``head_roll`` (the ``virtual`` profile's head controls,
   driven by F's head pose features) turn the ``Head`` bone: travel from neutral is ±1 of the
   feature's default range (±30°, ±20°, ±25°).

Other controls are ignored (logged once); a profile with none of these is refused. Right/left
are the performer's own, as in ARKit (``eyeBlinkLeft`` is the subject's left eye), and the
avatar copies the performer: a head turned toward the performer's left turns the avatar toward
its own left. Rotations are Unity's (left-handed, y up, the avatar facing +z), as VMC uses them.

python-osc comes with the ``[face]`` extra and is imported only when this driver is built.
"""

from __future__ import annotations

import logging
import math
import socket
import time
from collections.abc import Mapping
from typing import Annotated, Any

import msgspec

from facesynth.runtime.feature_names import BY_NAME
from facesynth.runtime.profiles import Profile, ServoSpec
from facesynth.services.control.core import CommandInfo
from facesynth.services.control.drivers._extras import require
from facesynth.services.control.drivers.base import DriverError, ServoDriver
from facesynth.services.control.drivers.registry import DRIVERS
from facesynth.services.control.drivers.servo_map import ProfileLimits

log = logging.getLogger("facesynth.control")

#: The 52 ARKit face blendshapes (Apple's ARFaceAnchor.BlendShapeLocation names).
ARKIT52: tuple[str, ...] = (
    "eyeBlinkLeft", "eyeLookDownLeft", "eyeLookInLeft", "eyeLookOutLeft", "eyeLookUpLeft",
    "eyeSquintLeft", "eyeWideLeft", "eyeBlinkRight", "eyeLookDownRight", "eyeLookInRight",
    "eyeLookOutRight", "eyeLookUpRight", "eyeSquintRight", "eyeWideRight", "jawForward",
    "jawLeft", "jawRight", "jawOpen", "mouthClose", "mouthFunnel", "mouthPucker", "mouthLeft",
    "mouthRight", "mouthSmileLeft", "mouthSmileRight", "mouthFrownLeft", "mouthFrownRight",
    "mouthDimpleLeft", "mouthDimpleRight", "mouthStretchLeft", "mouthStretchRight",
    "mouthRollLower", "mouthRollUpper", "mouthShrugLower", "mouthShrugUpper", "mouthPressLeft",
    "mouthPressRight", "mouthLowerDownLeft", "mouthLowerDownRight", "mouthUpperUpLeft",
    "mouthUpperUpRight", "browDownLeft", "browDownRight", "browInnerUp", "browOuterUpLeft",
    "browOuterUpRight", "cheekPuff", "cheekSquintLeft", "cheekSquintRight", "noseSneerLeft",
    "noseSneerRight", "tongueOut",
)  # fmt: skip

#: ``virtual`` control -> (blendshape of its travel above neutral, blendshape below neutral).
#: Gaze x is positive toward the performer's left: the right eye looks *in* (toward the nose),
#: the left eye *out*.
VIRTUAL_TO_ARKIT: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "brow_right": (("browOuterUpRight",), ("browDownRight",)),
    "brow_left": (("browOuterUpLeft",), ("browDownLeft",)),
    "lid_right": (("eyeWideRight",), ("eyeBlinkRight",)),
    "lid_left": (("eyeWideLeft",), ("eyeBlinkLeft",)),
    "gaze_right_x": (("eyeLookInRight",), ("eyeLookOutRight",)),
    "gaze_right_y": (("eyeLookUpRight",), ("eyeLookDownRight",)),
    "gaze_left_x": (("eyeLookOutLeft",), ("eyeLookInLeft",)),
    "gaze_left_y": (("eyeLookUpLeft",), ("eyeLookDownLeft",)),
    "cheek_right": (("cheekSquintRight",), ()),
    "cheek_left": (("cheekSquintLeft",), ()),
    "lip_corner_right": (("mouthSmileRight",), ("mouthFrownRight",)),
    "lip_corner_left": (("mouthSmileLeft",), ("mouthFrownLeft",)),
    "lower_lip": (("mouthLowerDownRight", "mouthLowerDownLeft"), ()),
    "jaw": (("jawOpen",), ()),
}
#: ``browInnerUp`` is the mean raise of these (a brow raise lifts its inner end too).
INNER_BROWS = ("brow_right", "brow_left")
#: Head pose controls and the degrees their full travel stands for (the features' ranges).
HEAD_CONTROLS = {
    name: BY_NAME[name].default_max for name in ("head_yaw", "head_pitch", "head_roll")
}


class VmcConfig(
    msgspec.Struct, tag="vmc", tag_field="driver", kw_only=True, forbid_unknown_fields=True
):
    """Send blendshapes and head pose to avatar software (VMC protocol over OSC/UDP)."""

    host: Annotated[
        str,
        msgspec.Meta(
            description="host of the VMC receiver (the avatar app; default 127.0.0.1)",
            extra={"flag": "--vmc-host"},
        ),
    ] = "127.0.0.1"
    port: Annotated[
        int,
        msgspec.Meta(
            ge=1, le=65535, description="its UDP port (default 39539)", extra={"flag": "--vmc-port"}
        ),
    ] = 39539
    head_position: Annotated[
        list[float],
        msgspec.Meta(
            min_length=3,
            max_length=3,
            description="local position X,Y,Z (m) sent with the Head bone's rotation, for "
            "receivers that apply bone positions: your model's head offset from its neck "
            "(default 0,0.08,0)",
        ),
    ] = msgspec.field(default_factory=lambda: [0.0, 0.08, 0.0])


class VmcError(ValueError):
    """A VMC setting or profile the driver cannot use."""


def sided(spec: ServoSpec, value: float) -> tuple[float, float]:
    """A control's travel from neutral toward max and toward min, each 0..1."""
    up = spec.max_us - spec.neutral_us
    down = spec.neutral_us - spec.min_us
    above = (value - spec.neutral_us) / up if up > 0 else 0.0
    below = (spec.neutral_us - value) / down if down > 0 else 0.0
    return min(1.0, max(0.0, above)), min(1.0, max(0.0, below))


def unity_quaternion(x_deg: float, y_deg: float, z_deg: float) -> tuple[float, float, float, float]:
    """``Quaternion.Euler(x, y, z)`` of Unity (z, then x, then y), as (x, y, z, w)."""

    def axis(index: int, degrees: float) -> tuple[float, float, float, float]:
        half = math.radians(degrees) / 2
        q = [0.0, 0.0, 0.0, math.cos(half)]
        q[index] = math.sin(half)
        return q[0], q[1], q[2], q[3]

    def product(a: tuple[float, ...], b: tuple[float, ...]) -> tuple[float, float, float, float]:
        ax, ay, az, aw = a
        bx, by, bz, bw = b
        return (
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        )

    return product(product(axis(1, y_deg), axis(0, x_deg)), axis(2, z_deg))


class AvatarMapping:
    """From a profile's control values to blendshape weights and a head rotation (pure)."""

    def __init__(self, profile: Profile) -> None:
        self.specs = {spec.name: spec for spec in profile.servos}
        arkit = set(ARKIT52)
        self.direct = [name for name in self.specs if name in arkit]
        self.virtual = [name for name in self.specs if name in VIRTUAL_TO_ARKIT]
        self.head = [name for name in self.specs if name in HEAD_CONTROLS]
        used = set(self.direct) | set(self.virtual) | set(self.head)
        self.ignored = sorted(set(self.specs) - used)
        if not used:
            raise VmcError(
                f"profile {profile.name!r} has no control the vmc driver can send (it takes ARKit "
                "blendshape names, the virtual profile's controls, head_yaw/pitch/roll)"
            )

    def blendshapes(self, positions: Mapping[str, float]) -> dict[str, float]:
        """Blendshape weights 0..1 by ARKit name."""
        weights: dict[str, float] = {}
        for name in self.direct:
            weights[name] = min(1.0, max(0.0, positions.get(name, 0.0) / 1000.0))
        for name in self.virtual:
            spec = self.specs[name]
            above, below = sided(spec, positions.get(name, spec.neutral_us))
            up_shapes, down_shapes = VIRTUAL_TO_ARKIT[name]
            for shape in up_shapes:
                weights[shape] = above
            for shape in down_shapes:
                weights[shape] = below
        brows = [b for b in INNER_BROWS if b in self.virtual]
        if brows and "browInnerUp" not in self.direct:
            raises = [
                sided(self.specs[b], positions.get(b, self.specs[b].neutral_us))[0] for b in brows
            ]
            weights["browInnerUp"] = sum(raises) / len(raises)
        return {name: round(value, 4) for name, value in weights.items()}

    def head_degrees(self, positions: Mapping[str, float]) -> dict[str, float] | None:
        """Yaw, pitch and roll in degrees (the features' signs); None without head controls."""
        if not self.head:
            return None
        degrees = {}
        for name, full in HEAD_CONTROLS.items():
            spec = self.specs.get(name)
            if spec is None:
                degrees[name] = 0.0
                continue
            above, below = sided(spec, positions.get(name, spec.neutral_us))
            degrees[name] = (above - below) * full
        return degrees

    def head_rotation(
        self, positions: Mapping[str, float]
    ) -> tuple[float, float, float, float] | None:
        """The Head bone's rotation for the avatar (Unity quaternion x, y, z, w), or None.

        Turning toward the performer's left is a negative turn about Unity's y (the avatar
        faces +z, its left is -x); chin up is a negative turn about x; a tilt toward the left
        shoulder a positive turn about z.
        """
        degrees = self.head_degrees(positions)
        if degrees is None:
            return None
        return unity_quaternion(-degrees["head_pitch"], -degrees["head_yaw"], degrees["head_roll"])


@DRIVERS.register(VmcConfig)
class VmcDriver(ServoDriver):
    """Send blendshapes and head pose to avatar software (VMC protocol over OSC/UDP)."""

    moves_hardware = False
    expected_profile = "arkit52"
    needs_extra = "face"
    shown_controls = frozenset(ARKIT52) | frozenset(VIRTUAL_TO_ARKIT) | frozenset(HEAD_CONTROLS)
    shown_controls_described = (
        "ARKit blendshape names, the virtual profile's controls and head_yaw/pitch/roll"
    )

    def __init__(self, config: VmcConfig, profile: Profile | None = None) -> None:
        require("pythonosc", plugin="vmc driver", package="python-osc", extra="face")
        if profile is None:
            raise VmcError("the vmc driver needs a profile")
        self.config = config
        self.mapping = AvatarMapping(profile)
        self.limits = ProfileLimits(profile)
        if self.mapping.ignored:
            log.warning("vmc: profile %s: ignored controls %s", profile.name, self.mapping.ignored)
        try:
            infos = socket.getaddrinfo(config.host, config.port, type=socket.SOCK_DGRAM)
        except (socket.gaierror, UnicodeError) as exc:
            raise VmcError(f"--vmc-host: cannot resolve {config.host!r}: {exc}") from None
        self._family: int = infos[0][0]
        self._address: tuple[Any, ...] = infos[0][4]
        self._socket: socket.socket | None = None
        self._started = 0.0
        self.count = 0
        self.errors = 0

    async def connect(self) -> None:
        sock = socket.socket(self._family, socket.SOCK_DGRAM)
        sock.setblocking(False)
        self._socket = sock
        self._started = time.monotonic()
        host, port = self._address[0], self._address[1]
        where = f"[{host}]:{port}" if ":" in str(host) else f"{host}:{port}"
        log.info("vmc: sending to %s over UDP (OSC; VMC receivers listen on 39539)", where)

    def bundle(self, positions: Mapping[str, float]) -> bytes:
        """The OSC bundle for one command."""
        from pythonosc.osc_bundle_builder import IMMEDIATELY, OscBundleBuilder
        from pythonosc.osc_message_builder import OscMessageBuilder

        def message(address: str, *args: Any) -> Any:
            builder = OscMessageBuilder(address=address)
            for arg in args:
                kind = "s" if isinstance(arg, str) else "i" if isinstance(arg, int) else "f"
                builder.add_arg(arg, kind)
            return builder.build()

        bundle = OscBundleBuilder(IMMEDIATELY)
        for name, value in self.mapping.blendshapes(positions).items():
            bundle.add_content(message("/VMC/Ext/Blend/Val", name, float(value)))
        bundle.add_content(message("/VMC/Ext/Blend/Apply"))
        rotation = self.mapping.head_rotation(positions)
        if rotation is not None:
            px, py, pz = self.config.head_position
            bundle.add_content(message("/VMC/Ext/Bone/Pos", "Head", px, py, pz, *rotation))
        bundle.add_content(message("/VMC/Ext/OK", 1))
        bundle.add_content(message("/VMC/Ext/T", float(time.monotonic() - self._started)))
        data: bytes = bundle.build().dgram
        return data

    async def send(self, positions: Mapping[str, float], info: CommandInfo) -> None:
        if self._socket is None:
            raise DriverError("vmc driver is not connected")
        data = self.bundle(self.limits.clamp(positions))
        try:
            self._socket.sendto(data, self._address)
        except OSError as exc:  # UDP: a receiver that is not there is not an error of ours
            self.errors += 1
            if self.errors <= 3 or self.errors % 1000 == 0:
                log.warning(
                    "vmc: cannot send to %s (%d so far): %s", self._address, self.errors, exc
                )
            return
        self.count += 1

    async def close(self) -> None:
        if self._socket is not None:
            self._socket.close()
            self._socket = None
