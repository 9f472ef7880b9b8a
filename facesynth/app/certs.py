"""``facesynth certs RIG``: a rig's certificate authority and one certificate per identity.

The CA (``ca.pem``, ``ca.key``) signs an X.509 v3 certificate for the router (server and client
use, with the names clients reach it by) and for each service identity (client use, the
identity as common name, which the router's access control reads). Keys are ECDSA P-256.
Every file is written atomically; private keys are readable by their owner only (0600).
An existing CA of the same rig is reused, so a lost service certificate can be reissued
without touching the others; ``ca.key`` is needed only here and belongs on no rig machine.
"""

from __future__ import annotations

import datetime
import ipaddress
import os
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from facesynth.app.secure import IDENTITIES, CertPaths, rig_configs
from facesynth.runtime import keys
from facesynth.runtime.atomic import write_atomic

#: Names the router's certificate always holds: its compose service name and loopback.
DEFAULT_ROUTER_NAMES = ("router", "localhost", "127.0.0.1")


class CertError(ValueError):
    """Certificates that cannot be made (missing library, another rig's CA, bad names)."""


@dataclass
class CertRequest:
    """What ``facesynth certs`` was asked to make."""

    rig: str
    out: Path
    router_names: list[str] = field(default_factory=list)
    identities: list[str] = field(default_factory=lambda: list(IDENTITIES))
    days: int = 825
    force: bool = False
    connect: list[str] = field(default_factory=lambda: ["tls/localhost:7447"])
    listen: list[str] = field(default_factory=lambda: ["tls/0.0.0.0:7447"])
    cert_dir: str | None = None


def _crypto() -> Any:
    try:
        from cryptography import x509
    except ImportError:
        raise CertError(
            "making certificates needs the 'cryptography' package: pip install 'facesynth[certs]'"
        ) from None
    return x509


def ca_name(rig: str) -> str:
    """The common name of a rig's CA (how a CA folder is matched to its rig)."""
    return f"facesynth rig {rig} CA"


def make_certs(request: CertRequest) -> list[Path]:
    """Make (or complete) a rig's certificate folder and its Zenoh configs; the files written."""
    _crypto()
    from cryptography import x509
    from cryptography.hazmat.primitives import serialization

    keys.check_name(request.rig)
    unknown = sorted(set(request.identities) - set(IDENTITIES))
    if unknown:
        raise CertError(f"unknown identities {unknown}; use {', '.join(IDENTITIES)}")
    if request.days < 1:
        raise CertError("--days must be at least 1")
    out = request.out
    written: list[Path] = []
    ca_cert_path, ca_key_path = out / "ca.pem", out / "ca.key"
    if ca_cert_path.exists() != ca_key_path.exists():
        raise CertError(f"{out}: ca.pem and ca.key must both be there, or neither")
    if ca_cert_path.exists():
        try:
            ca_cert = x509.load_pem_x509_certificate(ca_cert_path.read_bytes())
            ca_key = serialization.load_pem_private_key(ca_key_path.read_bytes(), password=None)
        except (ValueError, TypeError) as exc:
            raise CertError(f"{out}: unreadable CA ({exc})") from None
        found = ca_cert.subject.rfc4514_string()
        if found != f"CN={ca_name(request.rig)}":
            raise CertError(f"{out} holds another CA ({found}), not rig {request.rig!r}'s")
    else:
        ca_key = _new_key()
        ca_cert = _certificate(ca_name(request.rig), ca_key, days=3650)
        written += _write_pair(out, "ca", ca_cert, ca_key)
    for identity in request.identities:
        if (out / f"{identity}.pem").exists() and not request.force:
            continue
        key = _new_key()
        names = [*DEFAULT_ROUTER_NAMES, *request.router_names] if identity == "router" else []
        cert = _certificate(identity, key, request.days, (ca_cert, ca_key), names)
        written += _write_pair(out, identity, cert, key)
    paths = CertPaths(request.cert_dir or str(out.resolve()))
    for name, text in rig_configs(
        request.rig, paths, connect=request.connect, listen=request.listen
    ).items():
        written.append(write_atomic(out / name, text, mode=0o644))
    return written


def _new_key() -> Any:
    from cryptography.hazmat.primitives.asymmetric import ec

    return ec.generate_private_key(ec.SECP256R1())


def _now() -> datetime.datetime:
    return datetime.datetime.now(datetime.UTC)


def _certificate(
    common_name: str,
    key: Any,
    days: int,
    issuer: tuple[Any, Any] | None = None,
    names: Iterable[str] = (),
) -> Any:
    """A certificate of ``key`` for ``common_name``, valid ``days``: the rig's CA, self-signed,
    without an ``issuer``; else a leaf signed by ``issuer`` (the CA's certificate and key), for
    clients (and servers: the router) at the host ``names``."""
    from cryptography import x509
    from cryptography.hazmat.primitives import hashes
    from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

    ca = issuer is None
    subject = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, common_name)])
    signer = key if issuer is None else issuer[1]
    now = _now()
    builder = (
        x509.CertificateBuilder()
        .subject_name(subject)
        .issuer_name(subject if issuer is None else issuer[0].subject)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - datetime.timedelta(minutes=5))
        .not_valid_after(now + datetime.timedelta(days=days))
        .add_extension(x509.BasicConstraints(ca=ca, path_length=0 if ca else None), critical=True)
        .add_extension(
            x509.KeyUsage(
                digital_signature=True,
                content_commitment=False,
                key_encipherment=False,
                data_encipherment=False,
                key_agreement=False,
                key_cert_sign=ca,
                crl_sign=ca,
                encipher_only=False,
                decipher_only=False,
            ),
            critical=True,
        )
    )
    if ca:
        identifier = x509.SubjectKeyIdentifier.from_public_key(key.public_key())
        return builder.add_extension(identifier, critical=False).sign(key, hashes.SHA256())
    usages = [ExtendedKeyUsageOID.CLIENT_AUTH]
    if common_name == "router":  # it serves clients, and may link to other routers
        usages.insert(0, ExtendedKeyUsageOID.SERVER_AUTH)
    builder = builder.add_extension(x509.ExtendedKeyUsage(usages), critical=False).add_extension(
        x509.AuthorityKeyIdentifier.from_issuer_public_key(signer.public_key()), critical=False
    )
    alt = [_alt_name(name) for name in dict.fromkeys(names)]
    if alt:
        builder = builder.add_extension(x509.SubjectAlternativeName(alt), critical=False)
    return builder.sign(signer, hashes.SHA256())


def _alt_name(name: str) -> Any:
    from cryptography import x509

    try:
        return x509.IPAddress(ipaddress.ip_address(name))
    except ValueError:
        pass
    labels = name.split(".")
    if not name or not all(
        label and len(label) <= 63 and label.replace("-", "").isalnum() for label in labels
    ):
        raise CertError(f"--router-host {name!r} is neither an IP address nor a host name")
    return x509.DNSName(name)


def _write_pair(out: Path, stem: str, cert: Any, key: Any) -> list[Path]:
    from cryptography.hazmat.primitives import serialization

    key_pem = key.private_bytes(
        serialization.Encoding.PEM,
        serialization.PrivateFormat.PKCS8,
        serialization.NoEncryption(),
    )
    cert_pem = cert.public_bytes(serialization.Encoding.PEM)
    out.mkdir(parents=True, exist_ok=True)
    return [
        write_atomic(out / f"{stem}.key", key_pem, mode=0o600),
        write_atomic(out / f"{stem}.pem", cert_pem, mode=0o644),
    ]


def describe(written: list[Path], out: Path) -> str:
    """What was written, for the command's output."""
    if not written:
        return f"{out}: nothing to do"
    return "\n".join(
        f"{path}  ({oct(os.stat(path).st_mode & 0o777)[2:]})" for path in sorted(written)
    )
