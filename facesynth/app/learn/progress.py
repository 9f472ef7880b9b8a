"""Babbling progress on stderr: a bar with the time left on a terminal, a line every few seconds
otherwise. Pure but for the stream it writes to; time is data (monotonic seconds)."""

from __future__ import annotations

from typing import TextIO

#: Seconds between lines when stderr is not a terminal, and between redraws when it is.
LINE_EVERY_S = 2.0
DRAW_EVERY_S = 0.25
BAR = 24
#: What each phase of the babbler is called on the progress line.
PHASES = {
    "homing": "to neutral",
    "neutral": "learning the neutral face",
    "babbling": "babbling",
    "streaming": "streaming: learning from every frame",
    "paused": "paused: no face in view",
    "finishing": "back to neutral",
    "done": "done",
}


def clock_text(seconds: float) -> str:
    """``1:05`` or ``1:02:03``."""
    seconds = max(0, round(seconds))
    hours, rest = divmod(seconds, 3600)
    minutes, secs = divmod(rest, 60)
    return f"{hours}:{minutes:02d}:{secs:02d}" if hours else f"{minutes}:{secs:02d}"


class Progress:
    """Poses done of ``total`` (the session's, from ``first`` on resume), time left: the pace so
    far times the poses left, or the time budget if that ends sooner."""

    def __init__(
        self,
        stream: TextIO,
        *,
        first: int,
        total: int | None,
        started_s: float,
        until_s: float | None = None,
        tty: bool | None = None,
    ) -> None:
        self.stream = stream
        self.first = first
        self.total = total
        self.started_s = started_s
        self.until_s = until_s
        self.tty = stream.isatty() if tty is None else tty
        self._babble_s: float | None = None
        self._shown_s: float | None = None
        self._drawn = False

    def left_s(self, done: int, now_s: float) -> float | None:
        """Seconds left, once there is a pace to go by (or a time budget)."""
        left = None
        if self.total is not None and self._babble_s is not None and done > self.first:
            pace = (now_s - self._babble_s) / (done - self.first)
            left = pace * max(0, self.total - done)
        if self.until_s is not None:
            budget = max(0.0, self.until_s - now_s)
            left = budget if left is None else min(left, budget)
        return left

    def text(self, phase: str, done: int, now_s: float) -> str:
        """One progress line."""
        if phase == "babbling" and self._babble_s is None:
            self._babble_s = now_s
        elapsed = clock_text(now_s - self.started_s)
        total = f"/{self.total}" if self.total is not None else ""
        bar = ""
        if self.total:
            filled = round(BAR * min(1.0, done / self.total))
            bar = "[" + "#" * filled + "." * (BAR - filled) + "] "
        left = self.left_s(done, now_s) if phase != "done" else None
        left_text = f", {clock_text(left)} left" if left is not None else ""
        what = PHASES.get(phase, phase)
        return f"babbling {bar}{done}{total} poses ({what}), {elapsed} elapsed{left_text}"

    def update(self, phase: str, done: int, now_s: float, *, force: bool = False) -> None:
        """Show the progress if it is time to (or ``force``)."""
        every = DRAW_EVERY_S if self.tty else LINE_EVERY_S
        if not force and self._shown_s is not None and now_s - self._shown_s < every:
            if phase == "babbling" and self._babble_s is None:
                self._babble_s = now_s
            return
        self._shown_s = now_s
        line = self.text(phase, done, now_s)
        if self.tty:
            self.stream.write("\r\x1b[K" + line)
            self._drawn = True
        else:
            self.stream.write(line + "\n")
        self.stream.flush()

    def close(self) -> None:
        """End the bar's line on a terminal."""
        if self.tty and self._drawn:
            self.stream.write("\n")
            self.stream.flush()
