"""facesynth.app.doctor.outputs: the files the graph writes and facesynth's own folders,
written as their writers would (a probe file, so a path under a file or a read-only mount
shows even to root)."""

from __future__ import annotations

from pathlib import Path

from facesynth.app.doctor.outputs import output_findings, user_folders


def test_writable_places_and_the_ones_that_are_not(tmp_path: Path) -> None:
    blocker = tmp_path / "a-file"
    blocker.write_text("x")
    findings = output_findings(
        [
            ("record file", tmp_path / "out" / "commands.jsonl"),
            ("--record session", blocker / "s.mcap"),
        ],
        [("kept state", tmp_path / "state" / "deep")],
        [("profiles folder", Path("/proc/facesynth-profiles"))],
    )
    statuses = [(f.status.value, f.subject) for f in findings]
    assert statuses == [
        ("ok", str(tmp_path / "out" / "commands.jsonl")),
        ("fix", str(blocker / "s.mcap")),
        ("ok", str(tmp_path / "state" / "deep")),
        ("note", "/proc/facesynth-profiles"),
    ]
    assert findings[0].text.endswith("is made when first written)")
    assert "is not a directory" in findings[1].text
    assert not any(tmp_path.glob("**/.facesynth-doctor"))  # nothing left behind


def test_facesynth_folders_are_under_the_users_config(isolated_home: Path) -> None:
    folders = dict((what.split()[0], path) for what, path in user_folders())
    assert folders == {
        "calibrations": isolated_home / ".config" / "facesynth" / "calibrations",
        "profiles": isolated_home / ".config" / "facesynth" / "profiles",
    }
