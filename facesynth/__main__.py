"""``python -m facesynth`` runs the ``facesynth`` command."""

from facesynth.app.entry import main

raise SystemExit(main())
