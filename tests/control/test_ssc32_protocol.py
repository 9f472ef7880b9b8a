"""facesynth.services.control.drivers.ssc32.protocol against the SSC-32U user guide's examples."""

from __future__ import annotations

import pytest

from facesynth.services.control.drivers.ssc32 import protocol as sp


def test_group_moves() -> None:
    # Guide: "#5 P1600 #10 P750 T2500 <cr>" (spaces are optional).
    assert sp.group_move({5: 1600, 10: 750}, time_ms=2500) == b"#5P1600#10P750T2500\r"
    # Guide: "#5P1500S750<cr>".
    assert sp.group_move({5: 1500}, {5: 750}) == b"#5P1500S750\r"
    assert sp.group_move({2: 2250, 5: 1600}, {5: 0}) == b"#2P2250#5P1600\r"  # S0: no limit


def test_queries() -> None:
    assert sp.version() == b"VER\r"
    assert sp.query_moving() == b"Q\r"
    assert sp.query_pulse(31) == b"QP 31\r"


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: sp.group_move({32: 1500}), "channel 32"),
        (lambda: sp.group_move({0: 499}), "499 us is not in 500..2500"),
        (lambda: sp.group_move({0: 2501}), "2501 us"),
        (lambda: sp.group_move({}), "at least one channel"),
        (lambda: sp.group_move({0: 1500}, time_ms=0), "move time 0"),
        (lambda: sp.group_move({0: 1500}, time_ms=65536), "move time 65536"),
        (lambda: sp.query_pulse(-1), "channel -1"),
    ],
)
def test_values_that_cannot_be_encoded_are_refused(call: object, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        call()  # type: ignore[operator]
