"""``facesynth status``: the table of live services, with each service's state note."""

from __future__ import annotations

import msgspec

from facesynth.app.status import describe_link, describe_state, format_status
from facesynth.runtime import codec
from facesynth.runtime.stats import StageStats
from facesynth.schemas.messages import ServiceStats

S = 1_000_000_000


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
    assert line.startswith("r1")
    assert line.endswith("0.0  publishing; disconnected from /dev/ttyACM0 (3 attempts)")
    assert format_status(alive, {key: stats("")}).splitlines()[1].endswith("0.0  publishing")


def test_the_router_column_says_how_the_link_fared() -> None:
    key = "facesynth/r1/stats/control/host-1"
    alive = ["facesynth/r1/health/control/host-1"]
    lost = msgspec.structs.replace(
        stats("driver ok"), router_connected=True, router_losses=4, router_offline_s=79.71
    )
    header, line = format_status(alive, {key: lost}).splitlines()
    assert header.index("router") == line.index("up, lost 4x (79.7 s)")
    assert line.endswith("  publishing; driver ok")
    fresh = msgspec.structs.replace(stats(""), router_connected=True)
    assert (
        format_status(alive, {key: fresh})
        .splitlines()[1][header.index("router") :]
        .startswith("up ")
    )
    assert describe_link(stats("")) == "-"  # no router to lose (a router, an in-memory bus)
    down = msgspec.structs.replace(stats(""), router_connected=False, router_losses=1)
    assert describe_link(down) == "down, lost 1x (0.0 s)"


def test_a_stage_that_stopped_publishing_shows_no_rate_and_how_long_it_is_idle() -> None:
    """The sensor's video ended at 10 s: its figures, taken by the service at later times."""
    sensor = StageStats("sensor", "host-1", "r1")
    for frame in range(240):  # 24 fps for 10 s
        sensor.record_published(0, now_ns=frame * S // 24)
    last = 239 * S // 24
    key = "facesynth/r1/stats/sensor/host-1"
    alive = ["facesynth/r1/health/sensor/host-1"]
    header = format_status(alive, {}).splitlines()[0]
    rate_at = header.index("rate Hz")
    for after_s, rate, state in [
        (0.5, "21.6", "publishing"),
        (1.5, "0.0", "idle 2 s"),
        (3.5, "0.0", "idle 4 s"),
        (30.0, "0.0", "idle 30 s"),
    ]:
        snapshot = sensor.snapshot(now_ns=last + int(after_s * S))
        line = format_status(alive, {key: snapshot}).splitlines()[1]
        assert line[rate_at : rate_at + 8].strip() == rate, after_s
        assert line.endswith(f"  {state}"), line


def test_the_state_column_is_never_empty() -> None:
    fresh = msgspec.structs.replace(stats(""), published=0, rate_hz=0.0)
    assert describe_state(fresh) == "no output yet"
    idle = msgspec.structs.replace(stats(""), rate_hz=0.0, idle_s=12.4)
    assert describe_state(idle) == "idle 12 s"
    older = msgspec.structs.replace(stats(""), rate_hz=0.0)  # a service without idle_s
    assert describe_state(older) == "idle"
    stopped = msgspec.structs.replace(stats("stopped"), rate_hz=0.0, idle_s=0.2)
    assert describe_state(stopped) == "idle 0 s; stopped"


def test_each_stage_shows_its_stale_count_next_to_dropped_and_rejected() -> None:
    """P dropped 7 frames for their capture age, 2 for a full queue, rejected 1: its stats as
    published on the bus (encoded, decoded as ``facesynth status`` does) show all three."""
    points = StageStats("points", "host-1", "r1")
    points.received, points.dropped, points.rejected, points.stale = 40, 2, 1, 7
    for frame in range(30):
        points.record_published(0, now_ns=frame * S // 30)
    payload = codec.encode(points.snapshot(now_ns=S))
    key = "facesynth/r1/stats/points/host-1"
    alive = ["facesynth/r1/health/points/host-1"]
    header, line = format_status(alive, {key: codec.decode(payload, ServiceStats)}).splitlines()
    columns = header.split()
    assert columns[columns.index("drop") : columns.index("drop") + 3] == ["drop", "rej", "stale"]
    at = header.index("stale")
    assert line[at : at + 5] == "    7"
    assert line[header.index(" rej") : at].split() == ["1"]
    assert line[header.index(" drop") : header.index(" rej")].split() == ["2"]
