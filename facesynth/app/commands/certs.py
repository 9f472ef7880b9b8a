"""``facesynth certs RIG``: a rig's CA, certificates and secured Zenoh configs."""

from __future__ import annotations

import argparse
import logging
from pathlib import Path

from facesynth.app.command_registry import Command
from facesynth.runtime.atomic import write_atomic
from facesynth.runtime.bus.zenoh_bus import endpoints

log = logging.getLogger("facesynth")


def cmd_certs(args: argparse.Namespace) -> int:
    """``facesynth certs RIG``: a rig's CA, certificates and secured Zenoh configs."""
    from facesynth.app.certs import CertRequest, describe, make_certs
    from facesynth.app.secure import CertPaths, rig_configs

    out = Path(args.out)
    connect = endpoints(args.connect) or ["tls/localhost:7447"]
    listen = endpoints(args.listen) or ["tls/0.0.0.0:7447"]
    if args.configs_only:
        paths = CertPaths(args.cert_dir or str(out.resolve()))
        written = [
            write_atomic(out / name, text, mode=0o644)
            for name, text in rig_configs(args.rig, paths, connect=connect, listen=listen).items()
        ]
    else:
        request = CertRequest(
            rig=args.rig,
            out=out,
            router_names=args.router_host,
            days=args.days,
            force=args.force,
            connect=connect,
            listen=listen,
            cert_dir=args.cert_dir,
        )
        if args.identity:
            request.identities = args.identity
        written = make_certs(request)
    print(describe(written, out))
    return 0


HELP = (
    "make a rig's CA, a certificate per service and the Zenoh configs of a secured rig "
    "(mutual TLS, access control)"
)


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("rig", metavar="RIG", help="rig name (the configs' access control is for it)")
    p.add_argument("--out", default="certs", help="folder to write to (default ./certs)")
    p.add_argument(
        "--router-host",
        action="append",
        default=[],
        metavar="NAME",
        help="a host name or IP address clients reach the router by, put in its certificate "
        "(repeatable; 'router', 'localhost' and 127.0.0.1 are always in)",
    )
    p.add_argument(
        "--connect",
        action="append",
        metavar="ENDPOINT",
        help="the router endpoint written into the service configs (repeatable; default "
        "tls/localhost:7447)",
    )
    p.add_argument(
        "--listen",
        action="append",
        metavar="ENDPOINT",
        help="the endpoint written into the router config (default tls/0.0.0.0:7447)",
    )
    p.add_argument(
        "--cert-dir",
        metavar="PATH",
        help="where the hosts will keep these files, as the configs name them "
        "(default: --out, absolute)",
    )
    p.add_argument(
        "--identity",
        action="append",
        metavar="NAME",
        help="issue only these identities (repeatable; default all: sensor, points, features, "
        "translator, control, observer, router)",
    )
    p.add_argument(
        "--days", type=int, default=825, help="validity of the certificates (default 825 days)"
    )
    p.add_argument(
        "--force", action="store_true", help="reissue certificates that exist (the CA is kept)"
    )
    p.add_argument(
        "--configs-only",
        action="store_true",
        help="write only the Zenoh configs (no keys or certificates)",
    )


COMMANDS = (Command("certs", HELP, cmd_certs, _arguments),)
