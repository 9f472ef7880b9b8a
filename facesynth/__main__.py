"""``python -m facesynth`` runs the ``facesynth`` command."""

from facesynth.app.cli import main

raise SystemExit(main())
