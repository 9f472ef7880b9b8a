"""The chain's stages, registered like plugins: one module per stage (``sensor``, ``points``,
``features``, ``translator``, ``control``), each exporting ``STAGE``, its descriptor (node struct,
build function, consumed and produced keys, plugin table); see :mod:`.registry`.

The descriptors live in the application layer because building a node takes application parts
(the bundled video, the settled :class:`~facesynth.app.stages.setup.Setup`); the stages'
services (:mod:`facesynth.services`) stay independent of the application and of each other.
"""
