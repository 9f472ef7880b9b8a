"""The soak: the chain as real processes on loopback for hours, with a fault every minute.

``make soak HOURS=N`` (``python -m tools.soak``; not in CI) starts the fault suite's rig
(tests/faults: a ``facesynth router`` and the five stages, the bundled video looped through the
live tracker, commands recorded by C's ``record`` driver) and injects a fault every
``--interval`` seconds, round-robin: kill -9 of a stage or the router (then restarted), a stall
of points (SIGSTOP for 3 s, then SIGCONT), a flood on a key, a burst of oversized messages.
It samples every process's resident memory, and writes a report (printed at the end, written
atomically as JSON to ``runs/soak-<date>.json``, a progress line every few minutes).

The package's layout: :mod:`tools.soak.rss` (RSS series -> steps and slopes),
:mod:`tools.soak.commands` (record lines -> largest step, stale commands, gaps),
:mod:`tools.soak.report` and :mod:`tools.soak.schedule` are pure (data in, figures out;
tests/soak); :mod:`tools.soak.faults` (the injecting), :mod:`tools.soak.netns` (``--link-cuts``:
C on another network namespace, its link cut) and :mod:`tools.soak.run` (the processes) are the
shell. The shell reuses the fault suite's helpers (:mod:`tools.soak.rig`: its :class:`Rig`; its
flooder and big-message sender), the separate-hosts suite's namespaces, and
``tests/motion_check.py`` for the speed limits.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[2]
#: The fault suite's helpers live with the tests (they are not installed with facesynth).
TESTS = ROOT / "tests"
FAULTS = TESTS / "faults"
NETNS = TESTS / "netns"
for _folder in (TESTS, FAULTS, NETNS):
    if str(_folder) not in sys.path:
        sys.path.append(str(_folder))


def load_fault_rig() -> ModuleType:
    """The fault suite's rig module (tests/faults/conftest.py), imported once as ``fault_rig``
    (outside pytest its own name, ``conftest``, would be tests/conftest.py's). Only the shell
    needs it: the pure modules import nothing of pytest's."""
    if "fault_rig" not in sys.modules:
        spec = importlib.util.spec_from_file_location("fault_rig", FAULTS / "conftest.py")
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        sys.modules["fault_rig"] = module
        spec.loader.exec_module(module)
    return sys.modules["fault_rig"]
