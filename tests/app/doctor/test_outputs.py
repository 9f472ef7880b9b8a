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


def test_the_profiles_folder_label_says_who_writes_there(isolated_home: Path) -> None:
    """Issue 29: doctor said ``facesynth learn writes here`` while learn writes ``S.learned``
    beside its session; the label must say what each command really does."""
    from argparse import Namespace

    from facesynth.app.console.profile_file import save_path
    from facesynth.app.learn.cli import _profile_out

    label, folder = next((w, p) for w, p in user_folders() if w.startswith("profiles"))
    assert "facesynth learn writes here" not in label
    # the console saves a shipped profile into the folder …
    assert "facesynth console saves shipped profiles here" in label
    assert save_path(None, "head16").parent == folder
    # … learn writes beside its session unless --out-profile says otherwise
    assert "facesynth learn writes beside its session unless --out-profile" in label
    session = isolated_home / "runs" / "head.mcap"
    session.parent.mkdir()
    args = Namespace(out_profile=None)
    assert _profile_out(args, session) == session.with_suffix(".learned")
    assert _profile_out(args, session).parent != folder
