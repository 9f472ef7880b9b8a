"""``facesynth status``: the table of live services, with each service's state note."""

from __future__ import annotations

import msgspec

from facesynth.app.status import describe_link, format_status
from schemas.messages import ServiceStats


def stats(note: str) -> ServiceStats:
    return ServiceStats(
        service="control",
        instance="host-1",
        rig="r1",
        t_ns=1,
        uptime_s=3.0,
        received=10,
        published=10,
        dropped=0,
        rejected=0,
        rate_hz=30.0,
        note=note,
    )


def test_the_state_note_ends_its_line() -> None:
    key = "facesynth/r1/stats/control/host-1"
    alive = ["facesynth/r1/health/control/host-1"]
    table = format_status(alive, {key: stats("disconnected from /dev/ttyACM0 (3 attempts)")})
    header, line = table.splitlines()
    assert header.endswith("RSS MB  state")
    assert line.startswith("r1") and line.endswith("  disconnected from /dev/ttyACM0 (3 attempts)")
    assert format_status(alive, {key: stats("")}).splitlines()[1].endswith("0.0")


def test_the_router_column_says_how_the_link_fared() -> None:
    key = "facesynth/r1/stats/control/host-1"
    alive = ["facesynth/r1/health/control/host-1"]
    lost = msgspec.structs.replace(
        stats("driver ok"), router_connected=True, router_losses=4, router_offline_s=79.71
    )
    header, line = format_status(alive, {key: lost}).splitlines()
    assert header.index("router") == line.index("up, lost 4x (79.7 s)")
    assert line.endswith("  driver ok")
    fresh = msgspec.structs.replace(stats(""), router_connected=True)
    assert (
        format_status(alive, {key: fresh})
        .splitlines()[1][header.index("router") :]
        .startswith("up ")
    )
    assert describe_link(stats("")) == "-"  # no router to lose (a router, an in-memory bus)
    down = msgspec.structs.replace(stats(""), router_connected=False, router_losses=1)
    assert describe_link(down) == "down, lost 1x (0.0 s)"
