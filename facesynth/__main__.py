"""``python -m facesynth`` runs the ``facesynth`` command."""

from facesynth.cli import main

raise SystemExit(main())
