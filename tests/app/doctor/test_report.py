"""facesynth.app.doctor.report: findings to lines and a verdict (pure)."""

from __future__ import annotations

from facesynth.app.doctor.report import Finding, Status, blocking, lines, verdict


def test_a_finding_reads_as_what_the_graph_needs_makes_it() -> None:
    assert Finding("router", "r", "answers").status is Status.OK
    assert Finding("serial", "p", "no answer", good=None).status is Status.INFO
    assert Finding("extras", "learn", "missing", good=False).status is Status.NOTE
    assert Finding("extras", "face", "missing", good=False, needed=True).status is Status.FIX


def test_each_line_says_what_to_fix_when_something_is_missing() -> None:
    findings = [
        Finding("camera", "index 0 (/dev/video0)", "opens, 640x480"),
        Finding("extras", "face", "missing aiohttp", good=False, needed=True, fix="pip it"),
        Finding("extras", "learn", "missing\nscikit-learn", good=False, fix="pip  it"),
        Finding("serial", "/dev/ttyS0", "no answer", good=None, fix="never shown"),
    ]
    assert lines(findings) == [
        "ok   camera index 0 (/dev/video0): opens, 640x480",
        "fix  extras face: missing aiohttp: pip it",
        "note extras learn: missing scikit-learn: pip it",  # one line, whatever the text holds
        "info serial /dev/ttyS0: no answer",
    ]


def test_the_verdict_names_every_thing_to_fix_once() -> None:
    ok = [Finding("router", "tcp/x", "free"), Finding("extras", "learn", "x", good=False)]
    assert verdict(ok, "demo") is None and blocking(ok) == []
    fixes = [
        *ok,
        Finding("profile", "paper16 (node c)", "cannot", good=False, needed=True),
        Finding("profile", "paper16 (node c)", "cannot", good=False, needed=True),
        Finding("router", "tcp/x", "taken", good=False, needed=True),
    ]
    assert verdict(fixes, "face") == (
        "graph face cannot run on this host: 3 things to fix (profile paper16 (node c), "
        "router tcp/x), said above"
    )
    assert verdict(fixes[-1:], "face") == (
        "graph face cannot run on this host: 1 thing to fix (router tcp/x), said above"
    )
