"""The application: the ``facesynth`` command, the chain graph and its wiring, runners and
benchmarks. It uses the stages in ``services`` and the runtime library; nothing imports it."""
