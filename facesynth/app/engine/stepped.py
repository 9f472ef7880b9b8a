"""The chain's pure cores in one process, stepped frame by frame in virtual time.

What ``facesynth run`` runs as services on a bus, :class:`SteppedChain` runs as calls: a frame
(or a frame's points, or its features) goes through P (the points backend), F (the feature
processor) and, per robot, T (the translator, resuming from C's reports as the translator
service does) and C (the control core: checks, clamping, freshness, speed limits, its own
moves), each stage built by the same wiring as its service (:mod:`facesynth.app.wiring`), so the
profile, calibration, mirroring, F's neutral window, T's smoothing and C's motion options come
out as in ``run``. Time is data: ``t_ns`` is C's clock (for a ``--fast`` chain, the frames'
media time); C's own moves due before a frame (catch-up steps, reports, a return after a
silence longer than its watchdog) are made first, as its service makes them while it waits.

No frame is lost and none waits: each input gives exactly one output, so a run is
deterministic and aligned with its input (the renderer's video, the benchmarks). Nothing
touches a bus, a driver or a file; F keeps no learned state.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field

import msgspec
import numpy as np

from facesynth.app.nodes import ControlNode, TranslatorNode
from facesynth.app.stages.setup import Setup
from facesynth.app.wiring import OptionError, build_profile, build_translator
from facesynth.runtime.calibration import Calibration
from facesynth.runtime.clock import FAKE_EPOCH_NS
from facesynth.runtime.frames import encode_frame, local_encoding, tick_frame
from facesynth.runtime.profiles import Profile
from facesynth.schemas.messages import Features, Frame, Points, ServoCommands
from facesynth.services.control.core import Arrival, ControlCore, MotionTime, Move
from facesynth.services.control.drivers.registry import DRIVERS
from facesynth.services.features.core import FeatureProcessor
from facesynth.services.points.backends.base import PointsBackend
from facesynth.services.translator.core import Translator
from facesynth.services.translator.resume import ResumingTranslator

__all__ = [
    "RobotCores",
    "Step",
    "SteppedChain",
    "control_core",
    "motion_time_of",
    "sensor_frame",
]


def sensor_frame(
    image: np.ndarray | None,
    seq: int,
    t_media_ns: int,
    *,
    t_capture_ns: int = 0,
    encoding: str = "raw",
    quality: int = 90,
    fps: float = 0.0,
) -> Frame:
    """The frame message a sensor makes of ``image`` (``None``: a tick without pixels, as
    replayed point streams take), as P in the sensor's process takes it (``auto``: raw)."""
    if image is None:
        return tick_frame(seq=seq, t_capture_ns=t_capture_ns, t_media_ns=t_media_ns, fps=fps)
    return encode_frame(
        image,
        seq=seq,
        t_capture_ns=t_capture_ns,
        t_media_ns=t_media_ns,
        encoding=local_encoding(encoding),
        quality=quality,
        fps=fps,
    )


def motion_time_of(node: ControlNode, driver: msgspec.Struct | None, fast: bool) -> MotionTime:
    """What C measures speed limits on, decided as :func:`facesynth.app.wiring.build_control`
    does: the node's choice, else media time for a ``fast`` chain whose driver moves no
    hardware, else real time (``driver`` ``None``: no hardware)."""
    if node.motion_time is not None:
        return node.motion_time
    moves_hardware = False
    if driver is not None:
        factory = DRIVERS.get(str(driver.__struct_config__.tag)).factory
        moves_hardware = bool(getattr(factory, "moves_hardware", True))
    return "media" if fast and not moves_hardware else "real"


def control_core(
    node: ControlNode,
    driver: msgspec.Struct | None = None,
    fast: bool = False,
    setup: Setup | None = None,
) -> ControlCore:
    """The control core of a control node, as its service builds it (profile, mirroring,
    watchdog, motion time), without its driver; its profile from the chain's ``setup`` if
    given, else read now."""
    if setup is not None:
        profile = setup.profile(node.profile, node.mirror)
    else:
        profile = build_profile(node.profile, node.mirror)
    return ControlCore(
        profile, watchdog_s=node.watchdog, motion_time=motion_time_of(node, driver, fast)
    )


class RobotCores:
    """One robot's T and C: features in, the command T sends and the move C makes of it.

    T resumes from what C reports, as its service does from ``…/servo_state`` (at its first
    command, and after C moved on its own). Commands are stamped for C's freshness checks with
    ``t_ns`` on a fixed epoch (or the wall clock given), so they are never aged.
    """

    def __init__(self, name: str, translator: Translator, control: ControlCore) -> None:
        if control.profile.name != translator.profile.name:
            raise OptionError(
                f"{name}: the translator's profile {translator.profile.name} is not the "
                f"control's {control.profile.name}"
            )
        self.name = name
        self.translator = translator
        self.control = control
        self.resuming = ResumingTranslator(translator, sender=f"stepped-{name}", host="")
        self.started = False

    @classmethod
    def of_profile(
        cls,
        name: str,
        profile: Profile,
        *,
        calibration: Calibration | None = None,
        motion_time: MotionTime = "real",
        watchdog_s: float = 0.5,
    ) -> RobotCores:
        """T and C of one profile object (a profile not on disk, e.g. a benchmark's variant)."""
        translator = Translator(profile, calibration)
        control = ControlCore(profile, watchdog_s=watchdog_s, motion_time=motion_time)
        return cls(name, translator, control)

    @classmethod
    def from_nodes(
        cls,
        name: str,
        translator: TranslatorNode,
        control: ControlNode | None = None,
        *,
        driver: msgspec.Struct | None = None,
        fast: bool = False,
        setup: Setup | None = None,
    ) -> RobotCores:
        """T and C of a translator node and its control node (default: one with the
        translator's profile and mirroring), built as their services are; their profiles from
        the chain's ``setup`` if given (each file read once), else read now."""
        if control is None:
            control = ControlNode(profile=translator.profile, mirror=translator.mirror)
        return cls(
            name, build_translator(translator, setup), control_core(control, driver, fast, setup)
        )

    @property
    def profile(self) -> Profile:
        """The robot's profile (T's and C's)."""
        return self.control.profile

    def start(self, t_ns: int) -> Move:
        """C starts: the face at neutral."""
        self.started = True
        return self._seen(self.control.start(t_ns))

    def tick(self, now_ns: int) -> Move | None:
        """C's own move due at ``now_ns``, if any (:meth:`ControlCore.tick`), seen by T."""
        move = self.control.tick(now_ns)
        return self._seen(move) if move is not None else None

    def advance(self, t_ns: int) -> list[Move]:
        """C's own moves due up to ``t_ns`` (its start at ``t_ns`` if it has not started,
        catch-up steps, returns, reports), in order; those to send (every kind but ``report``)
        are returned."""
        sent = [] if self.started else [self.start(t_ns)]
        while (due := self.control.due_ns()) <= t_ns:
            move = self.tick(due)
            if move is None:
                break  # pragma: no cover - due_ns said something was due
            if move.send:
                sent.append(move)
        return sent

    def command(
        self, features: Features, t_ns: int, wall_ns: int | None = None
    ) -> tuple[ServoCommands, Move]:
        """T's command for ``features`` and C's move for it at ``t_ns`` (C starts first if it
        has not). C refuses a command with a ``ValueError`` (as its service would log it)."""
        if not self.started:
            self.start(t_ns)
        wall = FAKE_EPOCH_NS + t_ns if wall_ns is None else wall_ns
        commands = self.resuming.translate(features, wall)
        move, _ = self.control.command(commands, Arrival(wall, t_ns))
        return commands, self._seen(move)

    def _seen(self, move: Move) -> Move:
        """T sees C's report of ``move``, as on ``…/servo_state``."""
        state = ServoCommands(
            seq=0,
            t_capture_ns=0,
            t_media_ns=0,
            face=move.info.face,
            profile=self.profile.name,
            positions=move.positions,
            move=move.kind,
        )
        self.resuming.watch.see(state)
        return move


@dataclass(frozen=True)
class Step:
    """What each stage produced for one input: the frame and points (``None`` when not run),
    the features (``None`` without F), and per robot T's command, C's move for it and C's own
    moves sent before it (since the previous step)."""

    frame: Frame | None
    points: Points | None
    features: Features | None
    commands: dict[str, ServoCommands] = field(default_factory=dict)
    moves: dict[str, Move] = field(default_factory=dict)
    own: dict[str, list[Move]] = field(default_factory=dict)

    def positions(self, robot: str) -> dict[str, float]:
        """Where C sent ``robot``'s servos for this frame."""
        return self.moves[robot].positions


class SteppedChain:
    """P → F → T → C as calls, frame by frame, in virtual time (see the module doc).

    Any stage may be left out from the front: without a backend the input is points, without
    F it stops at the points (or takes features), without robots it stops at F.
    """

    def __init__(
        self,
        backend: PointsBackend | None = None,
        processor: FeatureProcessor | None = None,
        robots: Iterable[RobotCores] = (),
    ) -> None:
        self.backend = backend
        self.processor = processor
        self.robots = {robot.name: robot for robot in robots}

    def start(self, t_ns: int) -> dict[str, Move]:
        """Every robot's C starts at ``t_ns`` (else each starts at its first command)."""
        return {name: robot.start(t_ns) for name, robot in self.robots.items()}

    def step(self, item: Frame | Points | Features, t_ns: int | None = None) -> Step:
        """One frame, its points or its features through the stages after it, at ``t_ns`` on
        C's clock (default: the input's media time)."""
        t = item.t_media_ns if t_ns is None else t_ns
        frame = item if isinstance(item, Frame) else None
        points = item if isinstance(item, Points) else None
        if frame is not None:
            if self.backend is None:
                raise OptionError("this stepped chain has no points backend: step its points")
            points = self.backend.process(frame)
        if isinstance(item, Features):
            features = item
        elif self.processor is not None and points is not None:
            features = self.processor.process(points)
            self.processor.notes.clear()  # the service logs them; here nobody reads them
        else:
            return Step(frame, points, None)
        step = Step(frame, points, features)
        for name, robot in self.robots.items():
            step.own[name] = robot.advance(t)
            step.commands[name], step.moves[name] = robot.command(features, t)
        return step

    def run(self, items: Iterable[Frame | Points | Features]) -> Iterator[Step]:
        """:meth:`step` each input at its media time."""
        for item in items:
            yield self.step(item)
