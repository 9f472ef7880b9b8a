"""facesynth: real-time facial expression synthesis for robot and virtual faces."""

__version__ = "0.1.0"
