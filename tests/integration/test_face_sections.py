"""The paper's face-section expressions on the bundled video move the servos the right way.

The video (see facesynth/app/data/PROVENANCE.md) shows, by time: looking down (0-0.9 s), a sad
frown (2-3.5 s), looking up (7-8.8 s), a calm look with a soft closed-mouth smile (9.75-10.35 s,
the calibration's neutral), a smile (10.6-11.9 s) and a laugh with the mouth open (13.5-15.5 s).
No moment of it is a clean neutral, so the checks compare segments whose difference is plain to
see (looking up vs down, smiling or laughing vs the sad frown, brows raised while looking up vs
the frown). paper16's brows follow Table 1's nose distances, which get that last one wrong on
this video (head16 and virtual use the signed named features), so it is checked on those two.

Both tracker models run it: ``fast`` with paper16, head16 and virtual; ``full`` (the default)
with those and the blendshape-brow variants head16_bs and virtual_bs, except the vertical gaze
and lid checks: in the "looking down" second the performer's eyes are closed (MediaPipe's own
Face Landmarker scores eyeBlink 0.8 there), the full model's lids close with them and F holds the
gaze of closed eyes (the blink rule), so that segment is no "look down" for it. Vertical gaze,
with and without the lids following, and cross-talk are checked on synthetic faces with known
motion (tests/integration/test_face_sections_synthetic.py, tests/features).

``run`` tracks the raw pixels by default (the sensor's ``auto`` encoding), with the ``full``
model here; the ``fast`` model's runs track the JPEG a five-process chain's P gets
(``--encoding jpeg``): on the raw pixels its right brow barely tells looking up from the frown
on this video (look_up − frown: virtual brow_right 23 µs, head16 right_eyebrow 38 and
middle_eyebrow 44, against 302, 313 and 191 on the JPEG; the left brow 420/399 against
451/437; measured 2026-11-27), a fragility of that model's brows, not of the method.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from facesynth.app.data import sample_video
from facesynth.runtime.calibration import load_calibration
from facesynth.services.control.drivers.record import read_record

VIDEO = str(sample_video())
FPS = 23.976
SCHEDULE = (
    "look_down=0-0.9,frown=2-3.5,look_up=7-8.8,neutral=9.75-10.35,smile=10.6-11.9,"
    "open_mouth=13.5-15.5"
)
SEGMENTS = {
    "look_down": (0.0, 0.9),
    "frown": (2.0, 3.5),
    "look_up": (7.0, 8.8),
    "smile": (10.6, 11.9),
    "laugh": (13.5, 15.5),
}


def _facesynth(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "facesynth", *args], capture_output=True, text=True, timeout=180
    )


def _calibrate(model: str, tmp: Path) -> Path:
    path = tmp / f"performer-{model}.json"
    result = _facesynth(
        "calibrate",
        "performer",
        "--video",
        VIDEO,
        "--schedule",
        SCHEDULE,
        "--out",
        str(path),
        "--model",
        model,
    )
    assert result.returncode == 0, result.stderr
    assert "calibration 'performer' written" in result.stdout
    loaded = load_calibration(str(path))
    assert len(loaded.neutral_mesh) == 468 * 3 and loaded.named_neutral
    assert loaded.named_max["jaw_open"] > 0 > loaded.named_min["jaw_open"]
    assert ("mouthSmileLeft" in loaded.named_neutral) == (model == "full")
    return path


def _segment_means(
    calibration: Path, model: str, profile: str, tmp: Path
) -> dict[str, dict[str, float]]:
    out = tmp / f"{profile}-{model}.jsonl"
    result = _facesynth(
        "run",
        "--model",
        model,
        "--video",
        VIDEO,
        "--fast",
        "--calibration",
        str(calibration),
        "--profile",
        profile,
        "--out",
        str(out),
        "--listen",
        "tcp/127.0.0.1:0",
        *(["--encoding", "jpeg"] if model == "fast" else []),  # see the module doc
    )
    assert result.returncode == 0, result.stderr
    lines = [line for line in read_record(out) if line.frame is not None]
    assert len(lines) == 472 and all(line.face for line in lines)
    means = {}
    for name, (start, end) in SEGMENTS.items():
        chosen = [line.servos for line in lines if start <= line.frame / FPS < end]  # type: ignore[operator]
        means[name] = {servo: float(np.mean([s[servo] for s in chosen])) for servo in chosen[0]}
    return means


# (profile, servo, segment that must be higher, segment it is compared with, at least µs)
ORDERINGS = [
    ("virtual", "gaze_right_y", "look_up", "look_down", 50),
    ("virtual", "gaze_left_y", "look_up", "look_down", 50),
    ("virtual", "lip_corner_right", "smile", "frown", 100),
    ("virtual", "lip_corner_left", "smile", "frown", 100),
    ("virtual", "lip_corner_right", "laugh", "frown", 100),
    ("virtual", "lip_corner_left", "laugh", "frown", 100),
    ("virtual", "jaw", "laugh", "frown", 100),
    ("virtual", "lower_lip", "laugh", "frown", 100),
    ("virtual", "cheek_right", "smile", "look_up", 50),
    ("virtual", "cheek_left", "smile", "look_up", 50),
    ("virtual", "lid_right", "look_up", "look_down", 50),
    ("virtual", "lid_left", "look_up", "look_down", 50),
    ("virtual", "brow_right", "look_up", "frown", 100),
    ("virtual", "brow_left", "look_up", "frown", 100),
    ("head16", "right_eye_y", "look_up", "look_down", 50),
    ("head16", "left_eye_y", "look_up", "look_down", 50),
    ("head16", "right_eyebrow", "look_up", "frown", 100),
    ("head16", "left_eyebrow", "look_up", "frown", 100),
    ("head16", "middle_eyebrow", "look_up", "frown", 100),
    ("head16", "right_lip_corner", "smile", "frown", 100),
    ("head16", "left_lip_corner", "smile", "frown", 100),
    ("head16", "right_lip_corner", "laugh", "frown", 100),
    ("head16", "left_lip_corner", "laugh", "frown", 100),
    ("head16", "jaw", "laugh", "frown", 100),
    ("head16", "right_lower_lip", "laugh", "frown", 100),
    ("head16", "left_lower_lip", "laugh", "frown", 100),
    ("head16", "right_inner_cheek", "smile", "look_up", 50),
    ("head16", "left_inner_cheek", "smile", "look_up", 50),
    ("paper16", "right_eye_y", "look_up", "look_down", 50),
    ("paper16", "left_eye_y", "look_up", "look_down", 50),
    ("paper16", "jaw", "laugh", "frown", 100),
    ("paper16", "right_lower_lip", "laugh", "frown", 100),
    ("paper16", "left_lower_lip", "laugh", "frown", 100),
    ("paper16", "right_lip_corner", "smile", "frown", 100),
    ("paper16", "left_lip_corner", "smile", "frown", 100),
]


#: The profiles each model runs; a ``_bs`` variant is checked with its base's orderings.
PROFILES = {
    "fast": ("virtual", "head16", "paper16"),
    "full": ("virtual", "virtual_bs", "head16", "head16_bs", "paper16"),
}
#: Servos whose orderings compare the closed-eyed "looking down" second (see the module doc).
CLOSED_EYES = {"gaze_right_y", "gaze_left_y", "right_eye_y", "left_eye_y", "lid_right", "lid_left"}


def _cases() -> list[tuple[str, str, str, str, str, float]]:
    cases = []
    for model, profiles in PROFILES.items():
        for profile in profiles:
            base = profile.removesuffix("_bs")
            for name, servo, higher, lower, margin in ORDERINGS:
                if name != base or (model == "full" and servo in CLOSED_EYES):
                    continue
                cases.append((model, profile, servo, higher, lower, margin))
    return cases


CASES = _cases()


class Runs:
    """Each model's calibration and each (model, profile) run, made on first use."""

    def __init__(self, tmp: Path) -> None:
        self.tmp = tmp
        self.calibrations: dict[str, Path] = {}
        self.means: dict[tuple[str, str], dict[str, dict[str, float]]] = {}

    def __call__(self, model: str, profile: str) -> dict[str, dict[str, float]]:
        if model not in self.calibrations:
            self.calibrations[model] = _calibrate(model, self.tmp)
        if (model, profile) not in self.means:
            calibration = self.calibrations[model]
            self.means[(model, profile)] = _segment_means(calibration, model, profile, self.tmp)
        return self.means[(model, profile)]


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> Runs:
    return Runs(tmp_path_factory.mktemp("runs"))


@pytest.mark.parametrize(
    ("model", "profile", "servo", "higher", "lower", "margin"),
    CASES,
    ids=[f"{m}-{p}-{s}-{h}>{lo}" for m, p, s, h, lo, _ in CASES],
)
def test_expression_moves_servo_the_right_way(
    runs: Runs, model: str, profile: str, servo: str, higher: str, lower: str, margin: float
) -> None:
    means = runs(model, profile)
    up, down = means[higher][servo], means[lower][servo]
    assert up - down >= margin, f"{servo}: {higher} {up:.0f} µs vs {lower} {down:.0f} µs"
