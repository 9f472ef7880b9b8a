"""Sensor S, pure core: when each frame is due, and flow control for ``--fast`` replays.

Real-time pacing follows the media clock: frame ``n`` of a recording is due at
``start + t_media(n)``; a late frame is sent at once and the schedule is not shifted (so a slow
moment does not make the whole replay late). ``--fast`` sends frames as fast as the chain takes
them: at most ``window`` frames may be in flight ahead of the last servo command seen.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class Pacer:
    """Real-time schedule of a recording on the wall clock (all times in nanoseconds)."""

    start_ns: int | None = None
    first_media_ns: int = 0

    def delay_ns(self, t_media_ns: int, now_ns: int) -> int:
        """How long to wait before sending the frame at ``t_media_ns`` (0 if it is late)."""
        if self.start_ns is None:
            self.start_ns = now_ns
            self.first_media_ns = t_media_ns
            return 0
        due = self.start_ns + (t_media_ns - self.first_media_ns)
        return max(0, due - now_ns)

    def restart(self) -> None:
        """Start a new schedule (e.g. when a looped video wraps around)."""
        self.start_ns = None


@dataclass
class FlowWindow:
    """Credit-based flow control: frame ``seq`` may go once ``acked >= seq - window``."""

    window: int = 2
    acked: int = -1

    def __post_init__(self) -> None:
        if self.window < 1:
            raise ValueError("the flow window must be at least 1 frame")

    def ack(self, seq: int) -> None:
        """A downstream result for frame ``seq`` was seen."""
        self.acked = max(self.acked, seq)

    def may_send(self, seq: int) -> bool:
        """Whether frame ``seq`` may be sent now."""
        return self.acked >= seq - self.window


@dataclass
class SlowestCredit:
    """``--fast`` with several robots: credit comes from the slowest robot still answering.

    Each robot's control interface (or translator) acknowledges the frames it applied on its
    own key; :meth:`heard` keeps each robot's newest frame and returns the oldest of them over
    the robots heard from within ``stale_ns`` (a robot that stopped answering no longer holds
    the sensor back), so no robot falls behind by more than the window and loses frames. With
    one robot this is that robot's newest frame.
    """

    stale_ns: int
    newest: dict[str, tuple[int, int]] | None = None

    def heard(self, robot: str, seq: int, now_ns: int) -> int:
        """Robot ``robot`` applied frame ``seq`` at ``now_ns``: the credit now."""
        newest = self.newest if self.newest is not None else {}
        self.newest = newest
        previous = newest.get(robot, (-1, now_ns))[0]
        newest[robot] = (max(previous, seq), now_ns)
        answering = [s for s, at in newest.values() if now_ns - at <= self.stale_ns]
        return min(answering) if answering else seq
