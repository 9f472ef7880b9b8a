"""Babbling progress: a line every few seconds off a terminal, a bar in place on one, time left."""

from __future__ import annotations

import io

from facesynth.app.learn.progress import Progress, clock_text


def test_lines_every_two_seconds_with_the_time_left_from_the_pace() -> None:
    out = io.StringIO()
    progress = Progress(out, first=10, total=110, started_s=100.0, tty=False)
    progress.update("homing", 10, 100.0)
    progress.update("babbling", 10, 101.0)  # too soon for a line: only the pace's start
    progress.update("babbling", 20, 102.5)
    progress.update("babbling", 30, 111.0)
    lines = out.getvalue().splitlines()
    assert lines[0] == "babbling [##......................] 10/110 poses (to neutral), 0:00 elapsed"
    # 10 poses in 1.5 s since babbling began: 90 left take 13.5 s
    assert lines[1].endswith("20/110 poses (babbling), 0:02 elapsed, 0:14 left")
    assert lines[2].endswith("0:11 elapsed, 0:40 left")
    progress.update("done", 110, 150.0, force=True)
    assert out.getvalue().splitlines()[-1].endswith("(done), 0:50 elapsed")


def test_a_time_budget_bounds_the_time_left_and_a_terminal_redraws_in_place() -> None:
    out = io.StringIO()
    progress = Progress(out, first=0, total=None, started_s=0.0, until_s=60.0, tty=True)
    progress.update("babbling", 0, 0.0)
    progress.update("babbling", 5, 10.0)
    progress.close()
    text = out.getvalue()
    assert text.count("\r\x1b[K") == 2 and text.endswith("\n")
    assert "5 poses (babbling), 0:10 elapsed, 0:50 left" in text


def test_clock_text() -> None:
    assert [clock_text(s) for s in (0, 65, 3723, -3)] == ["0:00", "1:05", "1:02:03", "0:00"]
