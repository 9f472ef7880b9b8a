"""The ``facesynth`` commands that belong to no other package, one module each (each exports
``COMMANDS``; :mod:`facesynth.app.command_registry` lists the modules)."""
