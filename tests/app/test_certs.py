"""``facesynth certs``: a rig's CA, per-identity certificates and secured Zenoh configs."""

from __future__ import annotations

import datetime
import stat
from pathlib import Path

import pytest
import zenoh
from cryptography import x509
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

from facesynth.app.certs import CertRequest, make_certs
from facesynth.app.cli import main
from facesynth.app.secure import IDENTITIES, ROLES, CertPaths, access_control, rig_configs

ROOT = Path(__file__).resolve().parents[2]


def _cert(path: Path) -> x509.Certificate:
    return x509.load_pem_x509_certificate(path.read_bytes())


def _mode(path: Path) -> int:
    return stat.S_IMODE(path.stat().st_mode)


def test_a_ca_and_a_certificate_per_identity(tmp_path: Path) -> None:
    out = tmp_path / "certs"
    assert (
        main(
            [
                "certs",
                "lab",
                "--out",
                str(out),
                "--router-host",
                "10.0.0.1",
                "--router-host",
                "gw.lab",
            ]
        )
        == 0
    )
    ca = _cert(out / "ca.pem")
    assert ca.subject.rfc4514_string() == "CN=facesynth rig lab CA"
    assert ca.extensions.get_extension_for_class(x509.BasicConstraints).value.ca
    for identity in IDENTITIES:
        cert = _cert(out / f"{identity}.pem")
        cert.verify_directly_issued_by(ca)
        assert cert.subject.get_attributes_for_oid(NameOID.COMMON_NAME)[0].value == identity
        assert cert.version == x509.Version.v3
        usages = cert.extensions.get_extension_for_class(x509.ExtendedKeyUsage).value
        assert ExtendedKeyUsageOID.CLIENT_AUTH in usages
        assert (ExtendedKeyUsageOID.SERVER_AUTH in usages) == (identity == "router")
        assert not cert.extensions.get_extension_for_class(x509.BasicConstraints).value.ca
        assert isinstance(cert.public_key(), ec.EllipticCurvePublicKey)
        days = (cert.not_valid_after_utc - datetime.datetime.now(datetime.UTC)).days
        assert 820 <= days <= 825
        assert _mode(out / f"{identity}.key") == 0o600
        assert _mode(out / f"{identity}.pem") == 0o644
    assert _mode(out / "ca.key") == 0o600
    names = (
        _cert(out / "router.pem")
        .extensions.get_extension_for_class(x509.SubjectAlternativeName)
        .value
    )
    assert names.get_values_for_type(x509.DNSName) == ["router", "localhost", "gw.lab"]
    assert [str(ip) for ip in names.get_values_for_type(x509.IPAddress)] == [
        "127.0.0.1",
        "10.0.0.1",
    ]
    assert not list(out.glob("*.tmp")) and not list(out.glob(".*"))
    for config in out.glob("*.json5"):
        zenoh.Config.from_file(str(config))  # every config loads in Zenoh


def test_the_ca_is_reused_and_only_missing_certificates_are_made(tmp_path: Path) -> None:
    make_certs(CertRequest(rig="lab", out=tmp_path))
    ca_before = (tmp_path / "ca.pem").read_bytes()
    translator_before = (tmp_path / "translator.pem").read_bytes()
    (tmp_path / "control.pem").unlink()
    written = make_certs(CertRequest(rig="lab", out=tmp_path))
    assert {p.name for p in written if p.suffix != ".json5"} == {"control.pem", "control.key"}
    assert (tmp_path / "ca.pem").read_bytes() == ca_before
    assert (tmp_path / "translator.pem").read_bytes() == translator_before
    _cert(tmp_path / "control.pem").verify_directly_issued_by(_cert(tmp_path / "ca.pem"))

    make_certs(CertRequest(rig="lab", out=tmp_path, force=True, identities=["translator"]))
    assert (tmp_path / "translator.pem").read_bytes() != translator_before
    assert (tmp_path / "ca.pem").read_bytes() == ca_before


def test_configs_only_writes_no_keys(tmp_path: Path) -> None:
    assert main(["certs", "lab", "--out", str(tmp_path), "--configs-only"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        f"{name}.json5" for name in ["router", *ROLES]
    )


def _error(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("facesynth certs: error: ") and "Traceback" not in err
    return err


def test_another_rigs_ca_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    make_certs(CertRequest(rig="lab", out=tmp_path))
    err = _error(["certs", "other", "--out", str(tmp_path)], capsys)
    assert "holds another CA (CN=facesynth rig lab CA), not rig 'other''s" in err


@pytest.mark.parametrize(
    ("files", "argv", "expected"),
    [
        ({"ca.pem": "x"}, [], "ca.pem and ca.key must both be there"),
        ({"ca.pem": "garbage", "ca.key": "garbage"}, [], "unreadable CA"),
        ({}, ["--identity", "robot"], "unknown identities ['robot']"),
        ({}, ["--router-host", "bad host!"], "--router-host 'bad host!' is neither"),
        ({}, ["--connect", "tcp/router:7447"], "a secured rig uses tls/HOST:PORT endpoints"),
        ({}, ["--listen", "tcp/0.0.0.0:7447"], "--listen 'tcp/0.0.0.0:7447': a secured rig"),
        ({}, ["--days", "0"], "--days must be at least 1"),
    ],
)
def test_bad_requests_get_one_clear_error(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    files: dict[str, str],
    argv: list[str],
    expected: str,
) -> None:
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    assert expected in _error(["certs", "lab", "--out", str(tmp_path), *argv], capsys)


def test_bad_rig_name(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert "invalid rig name 'a/b'" in _error(["certs", "a/b", "--out", str(tmp_path)], capsys)


def _rules_allowing(rig: str, message: str, flow: str, key: str) -> set[str]:
    acl = access_control(rig)
    rules = {
        rule["id"]
        for rule in acl["rules"]
        if message in rule["messages"]
        and flow in rule["flows"]
        and any(zenoh.KeyExpr(e).includes(zenoh.KeyExpr(key)) for e in rule["key_exprs"])
    }
    return {
        subject
        for policy in acl["policies"]
        if rules & set(policy["rules"])
        for subject in policy["subjects"]
    }


@pytest.mark.parametrize(
    "key", ["facesynth/lab/servo_commands", "facesynth/lab/servo_commands/head1"]
)
def test_only_the_translator_publishes_and_only_control_subscribes_servo_commands(
    key: str,
) -> None:
    # The rig's commands and each robot's (keys.ROBOT_STAGES) alike.
    assert _rules_allowing("lab", "put", "ingress", key) == {"translator"}
    assert _rules_allowing("lab", "declare_subscriber", "ingress", key) == {"control"}
    assert _rules_allowing("lab", "put", "egress", key) == {"control"}
    assert _rules_allowing("lab", "put", "ingress", "facesynth/lab/servo_state/head1") == {
        "control"
    }
    acl = access_control("lab")
    assert acl["default_permission"] == "deny"
    assert {s["id"]: s["cert_common_names"] for s in acl["subjects"]} == {
        identity: [identity] for identity in ROLES
    }


def test_deploy_secure_configs_are_generated() -> None:
    expected = rig_configs(
        "default",
        CertPaths("/etc/facesynth-certs"),
        connect=["tls/router:7447"],
        listen=["tls/0.0.0.0:7447"],
    )
    found = {p.name: p.read_text() for p in (ROOT / "deploy" / "secure").glob("*.json5")}
    assert found == expected, (
        "deploy/secure is stale: facesynth certs default --configs-only --out deploy/secure "
        "--cert-dir /etc/facesynth-certs --connect tls/router:7447"
    )


def test_each_stage_s_access_comes_from_its_descriptor() -> None:
    """A stage publishes what its descriptor says it produces and subscribes to what it
    consumes; the chain's source also follows ``servo_state`` (credit for ``--fast``)."""
    from facesynth.app.stages.registry import STAGES

    assert [name for name in ROLES if name in STAGES] == list(STAGES.names())
    for stage in STAGES:
        publishes, subscribes = ROLES[stage.name]
        assert publishes == ((stage.produces,) if stage.produces else ())
        assert stage.consumes is None or subscribes[0] == stage.consumes
    assert ROLES["sensor"] == (("input",), ("servo_state",))
    assert ROLES["control"] == (("servo_state",), ("servo_commands",))
