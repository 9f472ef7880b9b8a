"""facesynth.services.sensor.core: real-time pacing on the media clock, and --fast flow control."""

from __future__ import annotations

import pytest

from facesynth.services.sensor.core import FlowWindow, Pacer, SlowestCredit

MS = 1_000_000


@pytest.mark.parametrize(
    ("schedule", "delays"),
    [
        # (t_media, now) pairs, all in ms; the first frame sets the schedule.
        ([(0, 1000), (40, 1000), (80, 1000)], [0, 40, 80]),
        ([(0, 1000), (40, 1040), (80, 1060)], [0, 0, 20]),
        ([(0, 1000), (40, 1100), (80, 1100), (120, 1100)], [0, 0, 0, 20]),
        ([(500, 1000), (540, 1000), (1500, 1900)], [0, 40, 100]),
        ([(0, 1000), (40, 1000), (40, 1050)], [0, 40, 0]),
        (
            [(1000, 5000), (1040, 5010), (1080, 5030), (1120, 5200), (1160, 5150)],
            [0, 30, 50, 0, 10],
        ),
    ],
    ids=[
        "early-waits",
        "on-time-and-early",
        "late-not-shifted",
        "media-starts-late",
        "repeated-media-time",
        "jitter",
    ],
)
def test_pacer_schedule(schedule: list[tuple[int, int]], delays: list[int]) -> None:
    pacer = Pacer()
    got = [pacer.delay_ns(media * MS, now * MS) // MS for media, now in schedule]
    assert got == delays


def test_late_frame_does_not_shift_the_schedule() -> None:
    pacer = Pacer()
    pacer.delay_ns(0, 0)
    assert pacer.delay_ns(40 * MS, 500 * MS) == 0  # 460 ms late
    # The next frames are still due at start + media time, not 500 ms later.
    assert pacer.delay_ns(520 * MS, 500 * MS) == 20 * MS
    assert pacer.start_ns == 0 and pacer.first_media_ns == 0


def test_restart_starts_a_new_schedule() -> None:
    pacer = Pacer()
    pacer.delay_ns(0, 1000 * MS)
    pacer.delay_ns(5000 * MS, 6000 * MS)
    pacer.restart()
    assert pacer.delay_ns(0, 9000 * MS) == 0  # looped video: media time back to 0
    assert pacer.delay_ns(40 * MS, 9000 * MS) == 40 * MS
    assert (pacer.start_ns, pacer.first_media_ns) == (9000 * MS, 0)


@pytest.mark.parametrize(
    ("window", "acked", "may", "may_not"),
    [
        (2, -1, [0, 1], [2, 3, 10]),
        (1, -1, [0], [1, 2]),
        (2, 5, [0, 5, 6, 7], [8, 9]),
        (4, 10, [11, 14], [15]),
    ],
    ids=["fresh-window-2", "fresh-window-1", "acked-5", "window-4"],
)
def test_flow_window(window: int, acked: int, may: list[int], may_not: list[int]) -> None:
    flow = FlowWindow(window=window)
    if acked >= 0:
        flow.ack(acked)
    assert all(flow.may_send(seq) for seq in may)
    assert not any(flow.may_send(seq) for seq in may_not)


def test_flow_window_keeps_at_most_window_frames_in_flight() -> None:
    flow = FlowWindow(window=3)
    sent = []
    for seq in range(20):
        if not flow.may_send(seq):
            flow.ack(sent[-3])  # the oldest in-flight result arrives
        assert flow.may_send(seq)
        sent.append(seq)
        in_flight = seq - flow.acked
        assert in_flight <= 3


def test_acks_out_of_order_never_go_back() -> None:
    flow = FlowWindow(window=2)
    flow.ack(7)
    flow.ack(3)
    assert flow.acked == 7
    assert flow.may_send(9) and not flow.may_send(10)


@pytest.mark.parametrize("window", [0, -1], ids=["zero", "negative"])
def test_flow_window_must_be_positive(window: int) -> None:
    with pytest.raises(ValueError, match="the flow window must be at least 1 frame"):
        FlowWindow(window=window)


S = 1_000_000_000


def test_one_robot_gives_its_newest_frame_as_credit() -> None:
    credit = SlowestCredit(stale_ns=2 * S)
    assert credit.heard("", 0, 0) == 0
    assert credit.heard("", 5, 1) == 5
    assert credit.heard("", 3, 2) == 5  # an older ack arriving late does not take credit back


def test_several_robots_give_the_slowest_answering_ones_frame() -> None:
    credit = SlowestCredit(stale_ns=2 * S)
    assert credit.heard("a", 4, 0) == 4
    assert credit.heard("b", 1, 0) == 1  # b is behind: the sensor waits for it
    assert credit.heard("a", 6, S) == 1
    assert credit.heard("b", 5, S) == 5
    # b stops answering: after stale_ns it no longer holds the sensor back.
    assert credit.heard("a", 9, 3 * S) == 5  # 2 s since b's last: still waited for
    assert credit.heard("a", 10, int(3.5 * S)) == 10
    assert credit.heard("b", 6, 4 * S) == 6  # and counts again once it answers
