"""The fault suite's rig (tests/faults/conftest.py: :class:`Rig`, ``ORDER``), for the shell."""

from tools.soak import load_fault_rig

load_fault_rig()

from fault_rig import ORDER, Rig  # noqa: E402

__all__ = ["ORDER", "Rig"]
