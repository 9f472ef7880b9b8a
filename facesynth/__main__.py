"""``python -m facesynth`` runs the ``facesynth`` command."""

from facesynth.app.entry import run

run()
