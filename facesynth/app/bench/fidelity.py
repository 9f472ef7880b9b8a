"""Fidelity: do synthetic expressions reach the right servos of every profile, with each model?

For ``facesynth bench fidelity``. Each expression of :mod:`facesynth.app.simhead.faces` (smile, brow
raise, frown, jaw drop, gaze in four directions, vertical gaze with the lids following) is
rendered on the still face, then goes through the real chain's cores: the tracker (the chosen
tracker model, LiteRT), then F (no calibration, the profile's neutral window on the still face)
and T of each profile, stepped as :class:`facesynth.app.engine.stepped.SteppedChain` runs
them; T's commands are measured. The still face is shown for 1.5 s
and the expression for 1 s at 30 fps; each image is tracked for a few frames until the crop
settles, and its points are replayed for the rest (a still image gives the same points every
frame once the crop holds).

Every servo belongs to a region (brows, gaze, lids, mouth, head: :func:`region`), and every
expression to one or two; an expression's *expected* servos must move the right way by at least
:data:`MIN_MOVE` of their travel, and the servos of the *other* regions must stay within
:data:`CROSS_TALK` of theirs (travel: from neutral to the limit on that side). Servos of the
expression's own region that are not expected (a smile also lifts the cheeks, a jaw drop also
moves the lip corners) are reported, not bounded.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Final

import msgspec
import numpy as np

from facesynth.app.engine.stepped import RobotCores, SteppedChain, sensor_frame
from facesynth.app.nodes import FeaturesNode
from facesynth.app.simhead.faces import BASE_FRAME, Face, base_face, expressions, render
from facesynth.app.wiring import build_processor
from facesynth.runtime.profiles import Profile, ServoSpec, load_profile
from facesynth.schemas.messages import Points
from facesynth.services.points.backends.tracker import TrackerBackend, TrackerConfig
from facesynth.services.points.tracker.offline import iter_video_frames

__all__ = [
    "CROSS_TALK",
    "MIN_MOVE",
    "PROFILES",
    "FidelityRow",
    "bench_fidelity",
    "expected_moves",
    "format_fidelity",
    "region",
]

FPS: Final = 30.0
NEUTRAL_S: Final = 1.5
EXPRESSION_S: Final = 1.0
SETTLE_FRAMES: Final = 4
#: An expected servo must move at least this share of its travel the right way.
MIN_MOVE: Final = 0.15
#: A servo of another region must stay within this share of its travel.
CROSS_TALK: Final = 0.2
#: The shipped profiles, in the order the tables show them.
PROFILES: Final = ("paper16", "head16", "head16_bs", "virtual", "virtual_bs", "arkit52")

#: Expression -> the regions whose servos it is allowed to move.
REGIONS: Final[dict[str, frozenset[str]]] = {
    "smile": frozenset({"mouth"}),
    "jaw_open": frozenset({"mouth"}),
    "brow_raise": frozenset({"brows", "lids"}),
    "frown": frozenset({"brows", "lids"}),
    **{
        f"look_{d}{s}": frozenset({"gaze", "lids"})
        for d in ("left", "right", "up", "down")
        for s in ("", "_lids")
    },
    "eyes_wide": frozenset({"lids"}),
    "squint": frozenset({"lids"}),
}


def region(servo: str) -> str:
    """The face region a servo (or blendshape control) belongs to, from its name."""
    lower = servo.lower()
    if lower.startswith("head_"):
        return "head"
    if "brow" in lower:
        return "brows"
    if "eye_x" in lower or "eye_y" in lower or "gaze" in lower or lower.startswith("eyelook"):
        return "gaze"
    if "lid" in lower or lower.startswith(("eyeblink", "eyesquint", "eyewide")):
        return "lids"
    return "mouth"


def _side_pairs(names: set[str], *pairs: tuple[str, str]) -> dict[str, int]:
    """``{servo: sign}`` for the (servo, sign) pairs whose servo the profile has."""
    out = {}
    for name, sign in pairs:
        if name in names:
            out[name] = 1 if sign == "+" else -1
    return out


def expected_moves(profile: Profile, expression: str) -> dict[str, int]:
    """The servos ``expression`` must move, and which way (+1 toward max_us, -1 toward min_us).

    By the shipped profiles' conventions: larger = raised (brows), open (jaw, lower lip),
    pulled up/out (lip corners), looking toward the performer's left / up (eyes); blendshape
    controls by their ARKit meaning (a right look is the right eye looking out, the left in).
    """
    names = {spec.name for spec in profile.servos}
    brows = [n for n in names if region(n) == "brows" and "Down" not in n]
    eyes_x = [n for n in names if n.endswith(("eye_x", "gaze_right_x", "gaze_left_x"))]
    eyes_y = [n for n in names if n.endswith(("eye_y", "gaze_right_y", "gaze_left_y"))]
    base = expression.removesuffix("_lids")
    if expression == "smile":
        return _side_pairs(
            names,
            *((n, "+") for n in ("right_lip_corner", "left_lip_corner")),
            *((n, "+") for n in ("lip_corner_right", "lip_corner_left")),
            *((n, "+") for n in ("mouthSmileLeft", "mouthSmileRight")),
        )
    if expression == "jaw_open":
        return _side_pairs(
            names,
            *((n, "+") for n in ("jaw", "right_lower_lip", "left_lower_lip", "lower_lip")),
            ("jawOpen", "+"),
        )
    if expression in ("brow_raise", "frown"):
        if any(n.startswith("brow") and n[4:5].isupper() for n in names):  # blendshapes
            if expression == "brow_raise":
                return {n: 1 for n in ("browInnerUp", "browOuterUpLeft", "browOuterUpRight")}
            return {n: 1 for n in ("browDownLeft", "browDownRight")}
        return {n: 1 if expression == "brow_raise" else -1 for n in brows}
    if expression in ("eyes_wide", "squint"):
        wide = expression == "eyes_wide"
        out = {n: 1 if wide else -1 for n in names if region(n) == "lids" and n.startswith("lid")}
        shapes = ("eyeWideLeft", "eyeWideRight") if wide else ("eyeSquintLeft", "eyeSquintRight")
        out.update({n: 1 for n in shapes if n in names})
        return out
    directions = {
        "look_left": (eyes_x, 1, ("eyeLookOutLeft", "eyeLookInRight")),
        "look_right": (eyes_x, -1, ("eyeLookInLeft", "eyeLookOutRight")),
        "look_up": (eyes_y, 1, ("eyeLookUpLeft", "eyeLookUpRight")),
        "look_down": (eyes_y, -1, ("eyeLookDownLeft", "eyeLookDownRight")),
    }
    servos, sign, shapes = directions[base]
    out = {n: sign for n in servos}
    out.update({n: 1 for n in shapes if n in names})
    return out


def _travel(spec: ServoSpec, delta: float) -> float:
    """``delta`` µs as a share of the servo's travel from neutral on that side."""
    span = spec.max_us - spec.neutral_us if delta >= 0 else spec.neutral_us - spec.min_us
    return delta / span if span > 0 else 0.0


@dataclass
class FidelityRow:
    """One expression through one profile with one model (moves as shares of travel)."""

    model: str
    profile: str
    expression: str
    expected: dict[str, float]
    worst_expected: tuple[str, float] | None
    cross_talk: tuple[str, float] | None
    own_region: tuple[str, float] | None
    right_way: bool
    within_bound: bool
    moves: dict[str, float] = field(default_factory=dict)


def _track(backend: TrackerBackend, image: np.ndarray, seq: int) -> Points:
    points: Points | None = None
    for i in range(SETTLE_FRAMES):
        points = backend.process(sensor_frame(image, seq + i, 0))
    assert points is not None
    if not points.face:
        raise RuntimeError(f"the {backend.tracker.model.name} model found no face")
    return points


def _sequence(neutral: Points, expression: Points) -> list[Points]:
    n0, n1 = round(NEUTRAL_S * FPS), round(EXPRESSION_S * FPS)
    out = []
    for i, source in enumerate([neutral] * n0 + [expression] * n1):
        t = round(i * 1e9 / FPS)
        out.append(msgspec.structs.replace(source, seq=i, t_capture_ns=t, t_media_ns=t))
    return out


def _rows(model: str, profile: Profile, name: str, stream: list[Points]) -> FidelityRow:
    # F with the profile's neutral window, T of the profile: T's commands are measured.
    processor = build_processor(FeaturesNode(), profile.neutral_seconds)
    robot = RobotCores.of_profile(profile.name, profile, motion_time="media")
    chain = SteppedChain(processor=processor, robots=[robot])
    n0 = round(NEUTRAL_S * FPS)
    positions = [step.commands[profile.name].positions for step in chain.run(stream)]
    before, after = positions[n0 - 1], positions[-1]
    specs = {spec.name: spec for spec in profile.servos}
    moves = {n: _travel(specs[n], after[n] - before[n]) for n in specs}
    expected = expected_moves(profile, name)
    signed = {n: sign * moves[n] for n, sign in expected.items()}
    allowed = REGIONS[name]
    others = {n: abs(v) for n, v in moves.items() if region(n) not in allowed}
    own = {n: abs(v) for n, v in moves.items() if region(n) in allowed and n not in expected}

    def worst(table: dict[str, float], highest: bool = True) -> tuple[str, float] | None:
        if not table:
            return None
        key = max(table, key=table.__getitem__) if highest else min(table, key=table.__getitem__)
        return key, table[key]

    worst_expected = worst(signed, highest=False)
    cross = worst(others)
    return FidelityRow(
        model=model,
        profile=profile.name,
        expression=name,
        expected=signed,
        worst_expected=worst_expected,
        cross_talk=cross,
        own_region=worst(own),
        right_way=worst_expected is None or worst_expected[1] >= MIN_MOVE,
        within_bound=cross is None or cross[1] <= CROSS_TALK,
        moves=moves,
    )


def still_face(video: str, frame: int = BASE_FRAME) -> Face:
    """The baseline face from ``frame`` of ``video``, its landmarks from the full model."""
    backend = TrackerBackend(TrackerConfig(model="full", blendshapes=False))
    frames = list(iter_video_frames(video, frame + 1))
    points: Points | None = None
    for i, image in enumerate(frames[max(0, frame - 30) :]):
        points = backend.process(sensor_frame(image, i, 0))
    assert points is not None and points.face
    mesh = next(s for s in points.sets if s.scheme == "mesh478")
    return base_face(frames[frame], np.reshape(mesh.coords, (478, 3)))


def bench_fidelity(
    video: str,
    models: Sequence[str] = ("fast", "full"),
    profiles: Sequence[str] = PROFILES,
) -> list[FidelityRow]:
    """Every expression through every profile with every model (see the module doc)."""
    face = still_face(video)
    catalogue = expressions(face)
    images = {e.name: render(face, e) for e in catalogue}
    loaded = [load_profile(name) for name in profiles]
    rows: list[FidelityRow] = []
    for model in models:
        backend = TrackerBackend(TrackerConfig(inference="litert", model=model))
        neutral = _track(backend, face.image, 0)
        for expression in catalogue:
            backend.tracker.reset()
            _track(backend, face.image, 0)
            stream = _sequence(neutral, _track(backend, images[expression.name], 100))
            rows.extend(_rows(model, profile, expression.name, stream) for profile in loaded)
    return rows


def _cell(item: tuple[str, float] | None) -> str:
    return "-" if item is None else f"{item[1]:+.2f} {item[0]}"


def format_fidelity(rows: Sequence[FidelityRow]) -> str:
    """One table per profile and model: per expression, the weakest expected move, the worst
    cross-talk and the largest move of the region's other servos (shares of travel)."""
    lines = [
        f"expected: >= {MIN_MOVE:.2f} of travel the right way; other regions: within "
        f"{CROSS_TALK:.2f}; moves as shares of travel (+ = the expected way)"
    ]
    keys: list[tuple[str, str]] = []
    for row in rows:
        if (row.profile, row.model) not in keys:
            keys.append((row.profile, row.model))
    for profile, model in keys:
        chosen = [r for r in rows if r.profile == profile and r.model == model]
        passed = sum(r.right_way and r.within_bound for r in chosen)
        lines.append("")
        lines.append(f"{profile} / {model}: {passed}/{len(chosen)} expressions pass")
        lines.append(
            f"  {'expression':15} {'ok':3} {'weakest expected':28} {'worst cross-talk':28} "
            f"{'same region, not expected':28}"
        )
        for r in chosen:
            ok = "yes" if r.right_way and r.within_bound else "NO"
            lines.append(
                f"  {r.expression:15} {ok:3} {_cell(r.worst_expected):28} "
                f"{_cell(r.cross_talk):28} {_cell(r.own_region):28}"
            )
    return "\n".join(lines)
