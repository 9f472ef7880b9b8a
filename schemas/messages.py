"""Message structs for every facesynth topic.

These are the wire format (msgpack, via msgspec) between independently deployed services, so
they evolve under strict rules (see ``schemas/README.md``):

* every struct has an explicit, stable tag in the ``type`` field; a tag is never reused;
* a new field always has a default, so old senders stay readable;
* a field is never retyped or renamed; a field that is no longer used keeps its default.

Every struct is frozen: stages in one process hand each other the message object itself
(``facesynth.runtime.bus.base.Bus.publish_message``), shared by every reader, so nobody may
change one after it is built (``msgspec.structs.replace`` makes a changed copy; the lists and
tables inside are shared too and are never changed in place).

Every message derived from a frame carries that frame's ``seq``, ``t_capture_ns`` (wall clock,
``time.time_ns()`` at capture) and ``t_media_ns`` (position in the recording, or time since the
live stream started), so latency can be measured at any stage and replays are deterministic.
``capture_host`` (added with the stale-motion rules; empty from older senders) names the clock
``t_capture_ns`` was read on (a kernel's, which every container of one machine shares,
``facesynth.runtime.clock_host``; a ROS 2 camera's, ``ros2:<topic>``; a host name from older
senders), for a live capture only: every stage and the control
interface drop a message captured longer ago than their limit, measured against that host's
clock offset as they see it (``facesynth.runtime.capture_age``). Replays of recordings and
``--fast`` sensors leave it empty: their capture stamps are not a live clock, and not aged.

Semantic checks that a type system cannot express (finite numbers, coordinate counts, frame
sizes) live in ``facesynth.runtime.codec``; this module holds structs only.
"""

from __future__ import annotations

from typing import Literal

import msgspec

TAG_FIELD = "type"

FrameEncoding = Literal["jpeg", "raw", "none"]


class Frame(msgspec.Struct, tag="frame", tag_field=TAG_FIELD, kw_only=True, frozen=True):
    """One image from the sensor (topic ``…/input``).

    ``encoding`` is ``"jpeg"`` (JPEG bytes), ``"raw"`` (BGR uint8, ``height*width*3`` bytes,
    row-major) or ``"none"`` (a timing tick without pixels, used when a point stream is replayed
    from a file and no image is needed).
    """

    seq: int
    t_capture_ns: int
    t_media_ns: int
    width: int
    height: int
    encoding: FrameEncoding
    data: bytes = b""
    source: str = ""
    fps: float = 0.0
    capture_host: str = ""


class PointSet(msgspec.Struct, kw_only=True, frozen=True):
    """Landmarks of one scheme, flattened: ``[x0, y0, (z0,) x1, y1, …]`` in frame pixels.

    Known schemes: ``ibug68`` (2D, the iBUG/CLM 68-point numbering used by the paper),
    ``mesh468`` (3D, the MediaPipe face mesh; z in the same pixel scale), ``mesh478`` (3D, Face
    Landmarker v2: the 468 mesh vertices then the right and the left iris, centre + 4 contour
    points each), ``iris10`` (2D, right iris centre + 4 contour points, then the left iris;
    right/left are the performer's own).
    """

    scheme: str
    dims: int
    coords: list[float]


class ScoreSet(msgspec.Struct, kw_only=True, frozen=True):
    """Named scores of one scheme, as values in the scheme's fixed order.

    Known scheme: ``blendshapes52`` (the 52 ARKit-style blendshapes in MediaPipe's order,
    ``facesynth.runtime.blendshapes.NAMES``; each in [0, 1]).
    """

    scheme: str
    values: list[float]


class Points(msgspec.Struct, tag="points", tag_field=TAG_FIELD, kw_only=True, frozen=True):
    """Face landmarks for one frame (topic ``…/points``).

    When ``face`` is false, ``sets`` and ``scores`` are empty: a missing face is said, never
    replaced by stale points. ``scores`` (added with the ``full`` tracker model) carries
    per-face scores such as the ``blendshapes52`` set; older senders leave it empty and older
    receivers ignore it.
    """

    seq: int
    t_capture_ns: int
    t_media_ns: int
    face: bool
    confidence: float = 0.0
    image_width: int
    image_height: int
    sets: list[PointSet] = []
    source: str = ""
    scores: list[ScoreSet] = []
    capture_host: str = ""


class Features(msgspec.Struct, tag="features", tag_field=TAG_FIELD, kw_only=True, frozen=True):
    """Pose-free features for one frame (topic ``…/features``).

    ``distances`` are the paper's features: the distance of each ``ibug68`` point to the nose tip
    (point 30) after rotation, translation and scale are removed with the outer eye corners
    (36, 45); unit = inter-ocular distance. ``deltas`` are the same relative to the performer's
    neutral face; they are only meaningful when ``neutral_ready`` is true.

    ``named`` are the named features of ``feature_names`` (head pose, gaze per eye,
    eye openness, brow, lid, cheek, lip and jaw actions), relative to neutral and scaled to the
    calibrated range (0 neutral, ±1 calibrated extremes); ``raw`` the same unscaled.
    ``displacements`` are each ibug68 point's movement from neutral in the eye-aligned face frame,
    flattened ``[dx0, dy0, dx1, …]`` in inter-ocular units, y up.
    """

    seq: int
    t_capture_ns: int
    t_media_ns: int
    face: bool
    neutral_ready: bool = False
    scheme: str = "ibug68"
    distances: list[float] = []
    deltas: list[float] = []
    named: dict[str, float] = {}
    raw: dict[str, float] = {}
    displacements: list[float] = []
    capture_host: str = ""


class ServoCommands(
    msgspec.Struct, tag="servo_commands", tag_field=TAG_FIELD, kw_only=True, frozen=True
):
    """Servo targets for one frame (topic ``…/servo_commands``).

    ``positions`` maps the profile's servo names to pulse widths in microseconds, already
    clamped to the profile's limits. ``face`` is false while no face is tracked (the positions
    then lead to neutral).

    Freshness (added with the control interface's motion safety; older senders leave the
    defaults and their commands are not aged): ``sender`` is the publishing service instance,
    ``sender_seq`` counts its messages from 1, ``sent_ns`` is its wall clock at publication and
    ``sender_host`` names the host whose clock that is. A controller drops a command that is
    not newer than one it applied from the same sender, or older than the profile's
    ``max_command_age_s``, measured against that host's clock offset as the controller sees it,
    and one whose frame was captured longer ago than that (``t_capture_ns`` on
    ``capture_host``, measured the same way; not when ``capture_host`` is empty).

    On ``…/servo_state`` the control interface reports every position it sends, and ``move``
    says why: ``"command"`` (a command applied; the default, and the only value on
    ``…/servo_commands``) or one of its own moves: ``"start"`` (neutral at start-up),
    ``"catch-up"`` (a step toward the last command's targets within the servos' speed limits),
    ``"return"`` (back to neutral after commands stopped), ``"stop"`` (back to neutral on
    shutdown) or ``"report"`` (nothing moved: where the servos are, while idle). For its own
    moves ``seq``, ``t_capture_ns`` and ``t_media_ns`` are those of the last command it applied
    (0 before any): flow control and drain checks count ``"command"`` states only.

    Read back (added with the smart bus servos; empty from drivers that cannot read their
    servos, and on ``…/servo_commands``): ``measured`` is each servo's measured position in
    µs, beside the commanded one in ``positions``; ``loads`` its signed load as a fraction of
    its maximum, ``temperatures_c`` its temperature, ``faults`` one line per servo reporting a
    hardware error (overload, overheating, voltage). Servos that report nothing are absent.
    """

    seq: int
    t_capture_ns: int
    t_media_ns: int
    face: bool
    profile: str
    positions: dict[str, float]
    sender: str = ""
    sender_seq: int = 0
    sent_ns: int = 0
    sender_host: str = ""
    move: str = "command"
    measured: dict[str, float] = {}
    loads: dict[str, float] = {}
    temperatures_c: dict[str, float] = {}
    faults: dict[str, str] = {}
    capture_host: str = ""


class ServiceStats(
    msgspec.Struct, tag="service_stats", tag_field=TAG_FIELD, kw_only=True, frozen=True
):
    """Periodic health figures of one running service (topic ``…/stats/<service>/<instance>``).

    Latencies are from the source frame's capture to this service's publication, in
    milliseconds, over the last ``window`` messages.
    """

    service: str
    instance: str
    rig: str
    t_ns: int
    uptime_s: float
    received: int
    published: int
    dropped: int
    rejected: int
    rate_hz: float
    latency_p50_ms: float | None = None
    latency_p99_ms: float | None = None
    rss_mb: float = 0.0
    peak_rss_mb: float = 0.0
    window: int = 0
    note: str = ""
    #: Connected to a Zenoh router when the figures were taken (``None``: no router to lose,
    #: e.g. a router's own session or an in-memory bus).
    router_connected: bool | None = None
    #: Times the service lost its last router since it started.
    router_losses: int = 0
    #: Seconds the service spent without a router since it first had one.
    router_offline_s: float = 0.0
    #: Seconds since the service last published a message (``None``: none yet, or a service
    #: older than this field); ``rate_hz`` is 0 once it has been idle for a second.
    idle_s: float | None = None
    #: Inputs dropped since the service started because their frame was captured longer ago
    #: than its limit (an upstream stall; ``facesynth.runtime.capture_age``); 0 from older
    #: services.
    stale: int = 0


class BabbleSample(
    msgspec.Struct, tag="babble_sample", tag_field=TAG_FIELD, kw_only=True, frozen=True
):
    """One settled pose of a babbling robot (topic ``…/babble``, from ``facesynth learn``).

    The robot was commanded ``commanded`` (pulse widths in µs by servo name, within the
    profile's limits), the control interface reported ``reported`` once it got there, and the
    robot's own camera then saw its face hold still: ``features`` are the face's raw named
    features (``Features.raw``, relative to the robot's neutral) averaged over the ``frames``
    settled frames, ``spread`` their standard deviations. ``seq`` is the pose's index in the
    babbling plan (``seed`` makes the plan; a resumed run continues it), ``kind`` what the pose
    is: ``"neutral"`` (the neutral re-checked), ``"sweep"`` (one servo alone) or ``"random"``;
    or ``"stream"``: one frame taken while the head moved along a trajectory (``facesynth learn
    --plan stream``), ``commanded`` the commands in force when it was taken, ``t_capture_ns``
    when it was taken, ``frames`` 1, not settled.
    ``settled`` is false when the face never held still within the longest wait (the last
    frames were taken). ``t_capture_ns`` is the wall clock when the pose settled,
    ``t_media_ns`` the time since babbling started.

    Where the driver reads the servos back, ``measured`` is where they reported themselves when
    the pose settled, and ``reached`` how they were known to be there: ``"measured"`` (read back
    within the tolerance), ``"measured timeout"`` (not within it in time) or ``"commanded"``
    (C reported the command, then a fixed wait); empty from older senders.
    """

    seq: int
    t_capture_ns: int
    t_media_ns: int
    profile: str
    kind: str
    commanded: dict[str, float]
    reported: dict[str, float] = {}
    features: dict[str, float] = {}
    spread: dict[str, float] = {}
    frames: int = 0
    settled: bool = True
    seed: int = 0
    measured: dict[str, float] = {}
    reached: str = ""


#: Every message struct, in tag order, for schema export and generic decoding.
ALL_MESSAGES: tuple[type[msgspec.Struct], ...] = (
    Frame,
    Points,
    Features,
    ServoCommands,
    ServiceStats,
    BabbleSample,
)
