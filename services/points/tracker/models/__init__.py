"""Bundled MediaPipe model files (data only; see PROVENANCE.md and LICENSE)."""
