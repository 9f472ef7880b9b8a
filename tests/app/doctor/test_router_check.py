"""facesynth.app.doctor.router: a real router answering (or not) where the graph looks, and the
security mode of the configs a rig uses (deploy/, and those ``facesynth certs`` writes)."""

from __future__ import annotations

from pathlib import Path

import pytest

from facesynth.app.cli import build_parser, main
from facesynth.app.doctor.command import router_need
from facesynth.app.doctor.router import probe_router, router_findings, security_mode
from facesynth.app.secure import CertPaths, rig_configs

REPO = Path(__file__).resolve().parents[3]


def need(*argv: str):  # type: ignore[no-untyped-def]
    return router_need(build_parser().parse_args(["doctor", *argv]))


def test_a_router_that_answers_a_client_graph(zenoh_router: str) -> None:
    wanted = need("--mode", "client", "--connect", zenoh_router)
    result = probe_router(wanted, timeout=2.0)
    assert result.router is not None and result.security == "plain"
    (finding,) = router_findings(result, wanted)
    assert finding.line() == f"ok   router   {zenoh_router}: router {result.router} answers (plain)"


def test_no_router_is_one_line_to_fix(unused_tcp: str) -> None:
    wanted = need("--mode", "client", "--connect", unused_tcp)
    (finding,) = router_findings(probe_router(wanted, timeout=1.0), wanted)
    assert finding.status.value == "fix"
    assert finding.line().startswith(f"fix  router   {unused_tcp}: no router answers (plain): ")
    assert finding.line().endswith("a secured rig needs its certificates (facesynth certs)")


def test_runs_own_router_needs_its_endpoint_free(zenoh_router: str, unused_tcp: str) -> None:
    taken = need("--listen", zenoh_router)
    (finding,) = router_findings(probe_router(taken, timeout=2.0), taken)
    assert finding.status.value == "fix" and "already listens there" in finding.text
    free = need("--listen", unused_tcp)
    (finding,) = router_findings(probe_router(free, timeout=1.0), free)
    assert finding.status.value == "ok" and finding.text.startswith("free: run's own router")


def test_doctor_exits_2_when_a_client_graph_has_no_router(
    unused_tcp: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.chdir(tmp_path)
    argv = ["doctor", "--mode", "client", "--connect", unused_tcp, "--timeout", "1"]
    assert main([*argv, "--log-level", "WARNING"]) == 2
    captured = capsys.readouterr()
    assert f"fix router {unused_tcp}: no router answers" in " ".join(captured.out.split())
    assert captured.err.strip().splitlines()[-1] == (
        f"facesynth doctor: error: graph demo cannot run on this host: 1 thing to fix (router "
        f"{unused_tcp}), said above"
    )


@pytest.mark.parametrize(
    ("endpoints", "tls", "side", "mode"),
    [
        (["tcp/127.0.0.1:7447"], {}, "connect", "plain"),
        (["tls/router:7447"], {"root_ca_certificate": "ca.pem"}, "connect", "TLS"),
        (["tls/router:7447"], {"enable_mtls": True}, "connect", "TLS"),  # no certificate of its own
        (
            ["tls/router:7447"],
            {"enable_mtls": True, "connect_certificate": "c"},
            "connect",
            "mutual TLS",
        ),
        (
            ["tls/0.0.0.0:7447"],
            {"enable_mtls": True, "listen_certificate": "r"},
            "listen",
            "mutual TLS",
        ),
        (["quic/router:7447"], {}, "connect", "TLS"),
    ],
)
def test_security_modes(endpoints: list[str], tls: dict[str, object], side: str, mode: str) -> None:
    assert security_mode(endpoints, tls, side) == mode


def test_the_mode_of_a_secured_rigs_configs(tmp_path: Path, unused_tcp: str) -> None:
    """The configs `facesynth certs` writes say mutual TLS; deploy/'s plain ones say plain."""
    configs = rig_configs(
        "default",
        CertPaths(str(tmp_path)),
        connect=["tls/localhost:7447"],
        listen=["tls/0.0.0.0:7447"],
    )
    observer = tmp_path / "observer.json5"
    observer.write_text(configs["observer.json5"])
    result = probe_router(need("--zenoh-config", str(observer), "--mode", "client"), timeout=0.5)
    assert result.security == "mutual TLS" and result.router is None
    deploy = str(REPO / "deploy" / "zenoh-service.json5")
    plain = probe_router(need("--zenoh-config", deploy, "--connect", unused_tcp), timeout=0.5)
    assert plain.security == "plain" and plain.router is None


@pytest.fixture
def unused_tcp() -> str:
    """A loopback TCP endpoint nothing listens on."""
    import socket

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    return f"tcp/127.0.0.1:{port}"


def test_runs_own_router_sees_a_secured_router_on_its_endpoint(tmp_path: Path) -> None:
    """A mutual-TLS router on the endpoint run's own router would listen on takes it, although
    no session opens to it with the router's own config (it has no client certificate)."""
    from facesynth.app.certs import CertRequest, make_certs
    from facesynth.runtime.bus.zenoh_bus import ZenohOptions, open_session, router_locators

    make_certs(CertRequest(rig="lab", out=tmp_path))
    config = str(tmp_path / "router.json5")
    running = open_session(
        ZenohOptions(mode="router", config_file=config, listen=["tls/127.0.0.1:0"])
    )
    try:
        (locator,) = router_locators(running)
        port = locator.rpartition(":")[2]
        taken = need("--zenoh-config", config, "--listen", f"tls/localhost:{port}")
        result = probe_router(taken, timeout=1.0)
        (finding,) = router_findings(result, taken)
    finally:
        running.close()
    assert result.security == "mutual TLS"
    assert finding.status.value == "fix", finding.line()
    assert finding.text.startswith("something already listens there (mutual TLS)"), finding.text


def _taken_by_run_default(locator: str):  # type: ignore[no-untyped-def]
    """run's default endpoint (no --listen, a graph with a sensor), here the test router's."""
    from dataclasses import replace

    default = need()
    assert default.free_port and default.options.listen == ["tcp/127.0.0.1:7447"]
    return replace(default, options=replace(default.options, listen=[locator]))


def test_a_taken_default_endpoint_is_info_run_takes_a_free_port(zenoh_router: str) -> None:
    """run falls back to a free port when its default endpoint is taken: doctor says so, and
    nothing is to fix."""
    taken = _taken_by_run_default(zenoh_router)
    result = probe_router(taken, timeout=2.0)
    (finding,) = router_findings(result, taken)
    assert finding.status.value == "info", finding.line()
    assert finding.line() == (
        f"info router   {zenoh_router}: router {result.router} already listens there (plain): "
        "run's own router will take a free port on 127.0.0.1 instead and log it (commands that "
        f"look on {zenoh_router} meet the other program; --listen chooses run's endpoint)"
    )


def test_doctor_and_run_agree_on_a_taken_endpoint(zenoh_router: str) -> None:
    """What doctor says about a taken endpoint is what run's own router does on it: a free port
    for run's default endpoint, a one-line error for an explicit --listen."""
    from facesynth.app.engine.router import open_embedded
    from facesynth.runtime.bus.zenoh_bus import ZenohConfigError, ZenohOptions

    session, locators = open_embedded([zenoh_router], ZenohOptions(mode="router"))
    session.close()
    assert locators and zenoh_router not in locators
    (info,) = router_findings(probe_router(_taken_by_run_default(zenoh_router)), need())
    explicit = need("--listen", zenoh_router)
    assert not explicit.free_port
    with pytest.raises(ZenohConfigError, match="Address already in use"):
        open_embedded([zenoh_router], ZenohOptions(mode="router"), fallback=False)
    (fix,) = router_findings(probe_router(explicit, timeout=2.0), explicit)
    assert (info.status.value, fix.status.value) == ("info", "fix")


def test_a_graph_without_a_sensor_keeps_its_endpoint(tmp_path: Path) -> None:
    """run serves a sensor-less graph (a robot host) where others look for it: no free port."""
    from facesynth.app.graph import load_graph

    graph_file = tmp_path / "host.toml"
    graph_file.write_text('[nodes.c]\nstage = "control"\ndriver = { driver = "record" }\n')
    args = build_parser().parse_args(["doctor", str(graph_file)])
    assert not router_need(args, load_graph(str(graph_file), plugins=False)).free_port
    assert router_need(args).free_port  # the demo graph has a sensor


def test_doctor_exits_0_when_runs_default_endpoint_is_taken(
    zenoh_router: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("facesynth.app.doctor.command.RUN_LISTEN", zenoh_router)
    assert main(["doctor", "--log-level", "WARNING"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert f"info router {zenoh_router}: router " in out
    assert "run's own router will take a free port on 127.0.0.1 instead" in out
    assert "graph demo can run on this host" in out
