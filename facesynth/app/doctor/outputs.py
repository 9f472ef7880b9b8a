"""Write access: the files the graph writes (record files, ``--record`` sessions, ``--render``
videos, F's kept state), checked as the writers check them before they start
(:func:`facesynth.runtime.outputs.check_output`: a probe file made and removed, so a read-only
mount shows even to root), and facesynth's own folders that other commands write into
(calibrations: ``facesynth calibrate``; profiles: ``facesynth console``, and ``facesynth learn
--out-profile`` when pointed there: by default it writes beside its session).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from facesynth.app.doctor.report import Finding
from facesynth.runtime.calibration import CALIBRATIONS
from facesynth.runtime.outputs import OutputError, check_output
from facesynth.runtime.profiles.loading import PROFILES

FAMILY = "folder"
#: The probe's name inside a folder (never created: only its folder is written to).
PROBE = ".facesynth-doctor"


def user_folders() -> list[tuple[str, Path]]:
    """facesynth's own folders other commands write to: calibrations and profiles."""
    return [
        ("calibrations folder (facesynth calibrate writes here)", CALIBRATIONS.user_dir()),
        (
            "profiles folder (profiles here are found by name; facesynth console saves "
            "shipped profiles here, facesynth learn writes beside its session unless "
            "--out-profile puts it here)",
            PROFILES.user_dir(),
        ),
    ]


def writable(path: Path, what: str, *, folder: bool) -> str | None:
    """None when a file can be written at ``path`` (or into folder ``path``), else why not."""
    try:
        if folder:
            check_output(path / PROBE, what, make_parents=True)
        else:
            check_output(path, what)
    except OutputError as exc:
        return str(exc)
    return None


def output_findings(
    outputs: Sequence[tuple[str, Path]],
    folders: Sequence[tuple[str, Path]],
    others: Sequence[tuple[str, Path]],
) -> list[Finding]:
    """One line per written file or folder: the graph's are needed, the others are notes."""
    findings = []
    for what, path in outputs:
        problem = writable(path, what, folder=False)
        findings.append(_finding(what, path, problem, needed=True, folder=False))
    for what, path in folders:
        problem = writable(path, what, folder=True)
        findings.append(_finding(what, path, problem, needed=True, folder=True))
    for what, path in others:
        problem = writable(path, what, folder=True)
        findings.append(_finding(what, path, problem, needed=False, folder=True))
    return findings


def _finding(what: str, path: Path, problem: str | None, *, needed: bool, folder: bool) -> Finding:
    subject = str(path)
    if problem is None:
        place = path if folder else path.parent
        made = "" if place.is_dir() else f" ({place} is made when first written)"
        return Finding(FAMILY, subject, f"{what}, writable{made}")
    return Finding(
        FAMILY,
        subject,
        problem,
        good=False,
        needed=needed,
        fix="choose a path you can write (e.g. under your home) or fix the folder's owner "
        "and permissions",
    )
