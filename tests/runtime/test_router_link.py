"""RouterLink: what a service logs and reports when it loses and regains its router."""

from __future__ import annotations

from facesynth.runtime.bus.link import RouterLink

S = 1_000_000_000


def test_first_connection_is_not_a_regain() -> None:
    link = RouterLink()
    assert link.opened("aaaaaaaa11", 0) == "connected to router aaaaaaaa"
    figures = link.figures(5 * S)
    assert (figures.connected, figures.losses, figures.offline_s) == (True, 0, 0.0)


def test_before_any_router_nothing_counts_as_offline() -> None:
    figures = RouterLink().figures(10 * S)
    assert (figures.connected, figures.losses, figures.offline_s) == (False, 0, 0.0)


def test_loss_and_regain_are_logged_with_the_outage() -> None:
    link = RouterLink()
    link.opened("r1", 0)
    lost = link.closed("r1", 10 * S)
    assert lost is not None and lost.startswith("lost router r1: no router now")
    during = link.figures(12 * S)
    assert (during.connected, during.losses, during.down_for_s, during.offline_s) == (
        False,
        1,
        2.0,
        2.0,
    )
    back = link.opened("r1", 14_500_000_000)
    assert back == "router r1 regained after 4.5 s without a router (lost 1 time so far)"
    after = link.figures(20 * S)
    assert (after.connected, after.losses, after.down_for_s, after.offline_s) == (True, 1, 0, 4.5)


def test_outages_add_up() -> None:
    link = RouterLink()
    link.opened("r1", 0)
    link.closed("r1", 1 * S)
    link.opened("r1", 2 * S)
    link.closed("r1", 3 * S)
    assert "(lost 2 times so far)" in (link.opened("r2", 6 * S) or "")
    assert link.figures(7 * S).offline_s == 4.0


def test_losing_one_of_two_routers_is_not_an_outage() -> None:
    link = RouterLink()
    link.opened("r1", 0)
    assert link.opened("r2", 0) == "also connected to router r2"
    assert link.closed("r1", S) == "lost router r1; still connected to another"
    assert link.figures(2 * S).losses == 0
    assert link.closed("unknown", S) is None
