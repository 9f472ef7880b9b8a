"""Record, replay and inspect a rig: MCAP recordings and a live Foxglove view.

* :mod:`.layout`: how a bus message becomes MCAP channels (JSON with its JSON Schema, Foxglove
  images and landmark annotations) and how the exact bus payload is rebuilt from them;
* :mod:`.writer` / :mod:`.reader`: chunked, crash-safe MCAP files and reading them back;
* :mod:`.check`: what a file holds, and recovering what a torn one still has;
* :mod:`.recorder`, :mod:`.replay`, :mod:`.live`: the ``record``, ``replay`` and ``inspect``
  services; :mod:`.convert`: OpenFace / track files in, JSON lines / CSV out.
"""

from facesynth.runtime.keys import APP_KEYS, STAGES

#: What ``record --keys`` can name: the five stages, ``babble`` (``facesynth learn``'s settled
#: poses) and ``stats`` (every service's stats).
RECORDABLE = (*STAGES, *APP_KEYS, "stats")
#: Stages ``replay --from`` can start from.
REPLAYABLE = ("input", "points", "features", "servo_commands")
