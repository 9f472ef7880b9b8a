"""Sample data shipped with facesynth (see PROVENANCE.md beside this file)."""

from __future__ import annotations

from pathlib import Path

DATA_DIR = Path(__file__).parent


def sample_video() -> Path:
    """The bundled performer video (640x360, 23.98 fps, 472 frames; Pexels licence)."""
    return DATA_DIR / "WolfgangLanger_Pexels.mp4"


def sample_openface_csv() -> Path:
    """Real OpenFace 2 FeatureExtraction output (100 frames, 68 landmarks)."""
    return DATA_DIR / "OpenFace_Test.csv"
