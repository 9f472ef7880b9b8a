"""The bus's promise, over a real Zenoh router: publishing never waits for a stopped subscriber.

See the Bus docstring. With Zenoh's BLOCK congestion control this fails: the publisher's ``put``
is held for seconds and every subscriber behind the router stalls until Zenoh gives up on the
stopped one (``python tests/bus/congestion_probe.py`` prints both side by side).
"""

from __future__ import annotations

from congestion_probe import measure

FRAMES = 400  # 20 MB at 200 frames/s: the hung subscriber's path fills after about 8 MB


async def test_a_stopped_subscriber_neither_blocks_the_publisher_nor_stalls_the_others() -> None:
    figures = await measure("bus", frames=FRAMES, rate=200.0, size=50_000)
    print(figures.line())
    # The premise: the hung subscriber's path really was congested (Zenoh dropped for it).
    assert figures.hung_received < 0.8 * FRAMES, figures.line()
    # The promise: publish returned at once, the loop kept running, the others kept receiving
    # (BLOCK: seconds for each). At this rate a loaded machine may cost the healthy subscriber
    # some messages too (DROP's price), never its stream.
    assert figures.put_max_s < 0.25, figures.line()
    assert figures.loop_lag_max_s < 1.0, figures.line()
    assert figures.healthy_gap_max_s < 1.0, figures.line()
    assert figures.healthy_received >= 0.5 * FRAMES, figures.line()
