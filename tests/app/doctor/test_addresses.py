"""facesynth.app.doctor.addresses: the servers a graph starts need their addresses free."""

from __future__ import annotations

import socket
from pathlib import Path

import pytest

from facesynth.app.cli import main
from facesynth.app.doctor.addresses import address_findings


@pytest.fixture
def taken() -> socket.socket:
    """A loopback port something listens on."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()
    yield server
    server.close()


def test_free_taken_and_malformed_addresses(taken: socket.socket) -> None:
    port = taken.getsockname()[1]
    findings = address_findings(
        [
            ("page", f"127.0.0.1:{port}", "--http"),
            ("page", "127.0.0.1:0", "--http"),
            ("view", "8080", "--foxglove"),
            ("view", "no.such.host.invalid:80", "--foxglove"),
        ]
    )
    assert [(f.status.value, f.text.split(":")[0]) for f in findings] == [
        ("fix", "taken"),
        ("ok", "any free port"),
        ("fix", "expected HOST"),
        ("fix", "cannot resolve 'no.such.host.invalid'"),
    ]
    assert findings[0].fix == "choose another with --http HOST:PORT (port 0 picks a free one)"
    assert [f.text for f in address_findings([("page", "host:99999", "--http")])] == [
        "expected HOST:PORT"
    ]


def test_a_taken_page_address_keeps_the_face_graph_from_running(
    taken: socket.socket,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.chdir(tmp_path)
    http = f"127.0.0.1:{taken.getsockname()[1]}"
    argv = [
        "doctor",
        "face",
        "--http",
        http,
        "--listen",
        "tcp/127.0.0.1:0",
        "--log-level",
        "WARNING",
    ]
    assert main(argv) == 2
    captured = capsys.readouterr()
    out = " ".join(captured.out.split())
    assert f"fix address {http} (control node page's live page): taken" in out
    assert f"(address {http} (control node page's live page))" in captured.err
