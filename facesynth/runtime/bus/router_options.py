"""How a facesynth router's Zenoh session differs from a service's: what keeps its memory flat.

A router lives longest and sees every publisher on the rig, so whatever Zenoh keeps per message
or per publisher adds up there first. Two settings, each measured on a ``facesynth router``
(eclipse-zenoh 1.10.2; figures in docs/tests.md, "The soak"):

* **Shared memory off** (``transport/shared_memory/enabled``). A session that receives a shared
  memory buffer maps the sender's whole pool (16 MiB) and its 1.25 MiB metadata segment, and
  never unmaps them, not even after the sender has exited (eclipse-zenoh/zenoh#2787 and #1700,
  open). Every publisher process that ever sent 3 KiB or more through a router (a flooding tool,
  a sensor restarted with raw frames) then stayed in the router's memory: +17 MB each, measured
  28 -> 86 MB of shared memory after four short-lived publishers, and 53 MB in a soak's router.
  With the router refusing shared memory no link through it uses any, so the services behind it
  (clients) never map a publisher's pool either; messages travel as bytes over the socket. Raw
  frames still pass (measured: no latency gain from shared memory, docs/benchmarks.md).
* **The largest message** (``transport/link/rx/max_message_size``) at
  :func:`facesynth.runtime.limits.router_limit`, instead of Zenoh's 1 GiB.

Both are overrides, so ``ZenohOptions.overrides`` set by the caller win.
"""

from __future__ import annotations

import dataclasses
from typing import Final

from facesynth.runtime import limits
from facesynth.runtime.bus.zenoh_bus import ZenohOptions

#: Zenoh's setting announcing (and accepting) shared memory buffers on a session's links.
SHM_ENABLED_PATH: Final = "transport/shared_memory/enabled"


def router_options(options: ZenohOptions) -> ZenohOptions:
    """``options`` for a router session: shared memory off and messages bounded by
    :func:`~facesynth.runtime.limits.router_limit` (unless ``options.overrides`` set them)."""
    bounded = options.with_message_limit(limits.router_limit())
    return dataclasses.replace(bounded, overrides={SHM_ENABLED_PATH: False, **bounded.overrides})
