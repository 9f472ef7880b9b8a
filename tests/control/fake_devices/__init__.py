"""Byte-level fake servo controllers on pseudo-terminals, for the driver tests.

Each fake is written from the device's public protocol description (not from facesynth's
encoders): it parses what a driver writes, keeps the positions, answers queries, and can be
unplugged and plugged in again at the same path (a symlink the test owns).
"""
