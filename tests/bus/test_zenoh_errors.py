"""Zenoh's errors as one line of ours (issue 20): the cause, no Rust source paths, the flag."""

from __future__ import annotations

import socket
from pathlib import Path

import pytest

from facesynth.runtime.bus.zenoh_bus import (
    ZenohConfigError,
    ZenohOptions,
    open_session,
    zenoh_cause,
)

#: As Zenoh 1.10 words them (seen with `facesynth router` on a busy port, and a client alone).
IN_USE = (
    "Can not create a new TCP listener bound to tcp/0.0.0.0:7447: [0.0.0.0:7447: Address already "
    "in use (os error 98) at /root/.cargo/git/checkouts/zenoh-9c599d5ef3e0480e/cc83980/io/"
    "zenoh-link-commons/src/tcp.rs:61.] at /root/.cargo/git/checkouts/zenoh-9c599d5ef3e0480e/"
    "cc83980/io/zenoh-links/zenoh-link-tcp/src/unicast.rs:338."
)
NO_ROUTER = (
    "Unable to connect to any of [Single(tcp/127.0.0.1:7447)]!  at /root/.cargo/git/checkouts/"
    "zenoh-9c599d5ef3e0480e/cc83980/zenoh/src/net/runtime/orchestrator.rs:447."
)


@pytest.mark.parametrize(
    ("text", "cause"),
    [
        (
            IN_USE,
            "Can not create a new TCP listener bound to tcp/0.0.0.0:7447: 0.0.0.0:7447: "
            "Address already in use",
        ),
        (NO_ROUTER, "Unable to connect to any of tcp/127.0.0.1:7447!"),
        ("plain words stay", "plain words stay"),
    ],
)
def test_the_cause_without_zenohs_internals(text: str, cause: str) -> None:
    assert zenoh_cause(text) == cause


def test_a_busy_listen_port_names_the_flag() -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        endpoint = f"tcp/127.0.0.1:{taken.getsockname()[1]}"
        with pytest.raises(ZenohConfigError) as error:
            open_session(ZenohOptions(mode="router", listen=[endpoint]))
    message = str(error.value)
    assert f"cannot open a Zenoh router session ({endpoint}):" in message
    assert "Address already in use - another program listens there" in message
    assert "with --listen" in message and ".rs" not in message and "os error" not in message


def test_a_broken_config_file_is_one_line_without_zenohs_internals(tmp_path: Path) -> None:
    path = tmp_path / "bad.json5"
    path.write_text("{ mode: ")
    with pytest.raises(ZenohConfigError) as error:
        ZenohOptions(config_file=str(path)).build()
    message = str(error.value)
    assert message.startswith(f"cannot load Zenoh config {path}: ")
    assert "\n" not in message and ".rs:" not in message and "expected array" in message
