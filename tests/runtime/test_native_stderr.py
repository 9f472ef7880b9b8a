"""Native chatter on fd 2: logged at DEBUG; every other line written back to fd 2."""

from __future__ import annotations

import logging
import os
import threading

import pytest

from facesynth.runtime.native_stderr import LITERT_CHATTER, chatter_to_log, sort_lines

LOG = logging.getLogger("test.native")


def test_chatter_goes_to_the_log_and_errors_back_to_fd_2(
    capfd: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.DEBUG, logger="test.native")
    with chatter_to_log(LOG, LITERT_CHATTER):
        os.write(2, b"INFO: Created TensorFlow Lite XNNPACK delegate for CPU.\n")
        os.write(2, b"ERROR: Didn't find op for builtin opcode 'FOO'\n")
    assert capfd.readouterr().err == "ERROR: Didn't find op for builtin opcode 'FOO'\n"
    assert [(r.levelno, r.getMessage()) for r in caplog.records] == [
        (logging.DEBUG, "INFO: Created TensorFlow Lite XNNPACK delegate for CPU.")
    ]


def test_fd_2_is_restored_when_the_block_raises(capfd: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(RuntimeError, match="bad model"), chatter_to_log(LOG, LITERT_CHATTER):
        os.write(2, b"ERROR: the model is broken\n")
        raise RuntimeError("bad model")
    os.write(2, b"after\n")
    assert capfd.readouterr().err == "ERROR: the model is broken\nafter\n"


def test_nothing_written_leaves_fd_2_as_it_was(capfd: pytest.CaptureFixture[str]) -> None:
    with chatter_to_log(LOG, LITERT_CHATTER):
        pass
    assert capfd.readouterr().err == ""


def test_two_threads_capturing_at_once_lose_no_line(capfd: pytest.CaptureFixture[str]) -> None:
    def write(n: int) -> None:
        with chatter_to_log(LOG, LITERT_CHATTER):
            os.write(2, f"INFO: chatter {n}\nERROR: real {n}\n".encode())

    threads = [threading.Thread(target=write, args=(n,)) for n in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert sorted(capfd.readouterr().err.splitlines()) == [f"ERROR: real {n}" for n in range(4)]


def test_sort_lines_keeps_other_lines_in_order() -> None:
    text = "INFO: a\nW0000 warning\n\nINFO: b\nERROR: c\nnot INFO: d\n"
    assert sort_lines(text, LITERT_CHATTER) == (
        ["INFO: a", "INFO: b"],
        ["W0000 warning", "ERROR: c", "not INFO: d"],
    )
