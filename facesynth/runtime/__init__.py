"""The runtime library: what every facesynth service imports.

The bus seam and its transports, message codecs, key names, the service context and its main
loop, clocks, stats, robot profiles and performer calibrations. It depends only on ``schemas``;
the stages in ``services`` build on it, and the application (``facesynth.app``) on both.
"""
