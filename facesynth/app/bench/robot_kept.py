"""The written profiles' likeness, kept: ``bench robot``'s figures pinned in a table.

The written profiles (paper16, head16, head16_bs) are measured on a segment of the bundled video,
:data:`SEGMENT_FRAMES` frames from frame :data:`SEGMENT_START`, on :data:`HEAD`, by the code
``facesynth bench robot`` runs (``track_performer``, ``bench_robot``; the segment plays as a
video of its own, F's neutral from its first second), and each profile's summary is kept in
``robot_kept.json`` beside this module. A test re-measures and fails when a figure went
backwards by more than :data:`TOLERANCE` (:func:`went_backwards`), so a change to F, T, C or
the tracker cannot silently make a written profile less alike. After a change that is meant to
move them, rewrite the table and say why in the commit:

    python -m facesynth.app.bench.robot_kept --write

The segment is short so that the test stays under a minute on a loaded 2-core machine (the
whole video takes about 30 s of CPU a profile): frames 200-319, five seconds in which she
stops crying (the neutral), then laughs with her head turned up to 24 degrees and chin up.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any, Final

from facesynth.runtime.atomic import write_atomic

from .robot import DEFAULT_PROFILES, RobotBench

__all__ = [
    "FIGURES",
    "HEAD",
    "KEPT_FILE",
    "SEGMENT_FRAMES",
    "SEGMENT_START",
    "TOLERANCE",
    "kept_table",
    "load_kept",
    "measure_kept",
    "went_backwards",
]

#: The table, in the repository beside this module.
KEPT_FILE: Final = Path(__file__).with_name("robot_kept.json")
#: The segment of the bundled video measured: its first frame and its length.
SEGMENT_START: Final = 200
SEGMENT_FRAMES: Final = 120
#: The simulated head the profiles drive.
HEAD: Final = "simhead16"
#: How far a figure may go backwards before the test fails (mean ρ; share of features with
#: their amplitude ratio in band; the median ratio's distance from 1).
TOLERANCE: Final = 0.05
#: The kept figures of each profile, as ``bench robot --json`` names them in its summary.
FIGURES: Final = ("mean_rho", "mean_rho_all_moved", "in_band", "median_ratio")


def kept_table(result: RobotBench) -> dict[str, Any]:
    """The figures to keep of a ``bench robot`` result: per head and profile, its summary."""
    from .robot_report import robot_json

    data = robot_json(result)
    return {
        "command": "python -m facesynth.app.bench.robot_kept --write",
        "video": "bundled sample",
        "start": SEGMENT_START,
        "frames": result.frames,
        "model": result.model,
        "tolerance": TOLERANCE,
        "heads": {
            head["head"]: {
                run["profile"]: {name: run["summary"][name] for name in FIGURES}
                for run in head["profiles"]
            }
            for head in data["heads"]
        },
    }


def load_kept(path: Path = KEPT_FILE) -> dict[str, Any]:
    """The kept table (raise ``ValueError`` with the path for a file that is not one)."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path}: not a kept bench robot table ({exc})") from None
    if not isinstance(data, dict) or not isinstance(data.get("heads"), dict):
        raise ValueError(f"{path}: not a kept bench robot table (no heads)")
    return data


def _worse_by(figure: str, kept: float, measured: float) -> float:
    """How much worse ``measured`` is than ``kept`` (negative: better)."""
    if figure == "median_ratio":  # an amplitude ratio is best at 1
        return abs(measured - 1.0) - abs(kept - 1.0)
    return kept - measured


def went_backwards(
    kept: dict[str, Any], measured: dict[str, Any], tolerance: float = TOLERANCE
) -> list[str]:
    """One line per figure of the kept table that ``measured`` (a :func:`kept_table`) lost by
    more than ``tolerance``, or does not have; empty when every kept figure holds."""
    lines = []
    for head, profiles in kept["heads"].items():
        for profile, figures in profiles.items():
            now = measured["heads"].get(head, {}).get(profile)
            if now is None:
                lines.append(f"{head} / {profile}: not measured")
                continue
            for figure, was in figures.items():
                if was is None:
                    continue
                value = now.get(figure)
                if value is None or not math.isfinite(value):
                    lines.append(f"{head} / {profile}: {figure} {was:.3f} -> none")
                elif _worse_by(figure, was, value) > tolerance:
                    lines.append(
                        f"{head} / {profile}: {figure} {was:.3f} -> {value:.3f} "
                        f"(worse by more than {tolerance})"
                    )
    return lines


def measure_kept() -> dict[str, Any]:
    """The written profiles on :data:`HEAD` over the segment, as a :func:`kept_table`."""
    from facesynth.app.data import sample_video
    from facesynth.app.simhead import SimHead, load_head

    from .robot import bench_robot, track_performer

    performance = track_performer(str(sample_video()), frames=SEGMENT_FRAMES, start=SEGMENT_START)
    config = load_head(HEAD)
    result = bench_robot(performance, [HEAD], DEFAULT_PROFILES, lambda _: SimHead(config))
    return kept_table(result)


def main(argv: list[str] | None = None) -> int:
    """Measure, print each figure against the kept one; ``--write`` rewrites the table."""
    parser = argparse.ArgumentParser(prog="python -m facesynth.app.bench.robot_kept")
    parser.add_argument("--write", action="store_true", help="rewrite the kept table")
    args = parser.parse_args(argv)
    measured = measure_kept()
    kept = load_kept() if KEPT_FILE.exists() else {"heads": {}}
    for head, profiles in measured["heads"].items():
        for profile, figures in profiles.items():
            was = kept["heads"].get(head, {}).get(profile, {})
            cells = "  ".join(
                f"{name} {_text(was.get(name))} -> {_text(value)}"
                for name, value in figures.items()
            )
            print(f"{head} / {profile}: {cells}")
    for line in went_backwards(kept, measured):
        print(f"went backwards: {line}")
    if args.write:
        write_atomic(KEPT_FILE, json.dumps(measured, indent=2) + "\n", mode=0o644)
        print(f"wrote {KEPT_FILE}")
    return 0


def _text(value: float | None) -> str:
    return "none" if value is None else f"{value:.3f}"


if __name__ == "__main__":
    sys.exit(main())
