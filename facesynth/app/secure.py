"""A secured rig's Zenoh configs: mutual TLS on every link, access control on the router.

Every service proves who it is with a certificate from the rig's CA (``facesynth certs``); its
common name is its *identity*: one of the five stages, ``observer`` (``facesynth status`` and
``facesynth health``, read only) or ``router``. The router refuses a link without a certificate
from the rig's CA, and its access-control policy lets each identity do only its stage's part:

- only ``translator`` may publish ``facesynth/<rig>/servo_commands`` (and each robot's
  ``…/servo_commands/<robot>``), and only ``control`` may subscribe to it (or receive it);
- each stage publishes its own key, its stats and its liveliness token, and subscribes to the
  key it consumes; nothing else is allowed (``default_permission: deny``).

Services are Zenoh clients here: a peer would open direct links past the router's control.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import PurePath
from typing import Any

from facesynth.app.stages.registry import STAGES
from facesynth.runtime import keys

#: Keys a stage reads beyond the one it consumes: the chain's source (the sensor) may follow
#: ``servo_state`` (credit for ``--fast``).
FOLLOWS: dict[str, tuple[str, ...]] = {source: ("servo_state",) for source in STAGES.sources()}
#: Keys each identity publishes and subscribes to beyond its own stats and liveliness token:
#: each stage's from its descriptor (what it produces; what it consumes, and follows);
#: observers read the rig's health figures and what the controllers applied.
ROLES: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    **{
        stage.name: (
            (stage.produces,) if stage.produces else (),
            ((stage.consumes,) if stage.consumes else ()) + FOLLOWS.get(stage.name, ()),
        )
        for stage in STAGES
    },
    "observer": ((), ("servo_state", "stats/**", "health/**")),
}
#: Every identity a rig's CA issues a certificate for.
IDENTITIES: tuple[str, ...] = (*ROLES, "router")

#: How fast links notice a cut and come back (the values of deploy/zenoh-*.json5).
LINK_TUNING: dict[str, Any] = {
    "lease": 1000,
    "keep_alive": 4,
    "open_timeout": 1000,
    "retry": {"period_init_ms": 100, "period_max_ms": 500, "period_increase_factor": 2},
}


class SecureConfigError(ValueError):
    """Options that cannot make a secured rig's configs."""


@dataclass(frozen=True)
class CertPaths:
    """Where a host finds the rig's certificates (as the configs name them)."""

    folder: str

    def ca(self) -> str:
        return str(PurePath(self.folder) / "ca.pem")

    def cert(self, identity: str) -> str:
        return str(PurePath(self.folder) / f"{identity}.pem")

    def key(self, identity: str) -> str:
        return str(PurePath(self.folder) / f"{identity}.key")


def _key_expr(prefix: str, key: str) -> str:
    """A role's key: a robot stage's covers the bare key and every robot's (``…/head1``)."""
    return f"{prefix}/{key}/**" if key in keys.ROBOT_STAGES else f"{prefix}/{key}"


def _allow(rule: str, messages: list[str], flow: str, key_exprs: list[str]) -> dict[str, Any]:
    """An access-control rule: ``messages`` on ``key_exprs`` allowed one way (in or out)."""
    return {
        "id": rule,
        "messages": messages,
        "flows": [flow],
        "permission": "allow",
        "key_exprs": key_exprs,
    }


def access_control(rig: str) -> dict[str, Any]:
    """The router's access-control section for ``rig``: each identity its stage's part."""
    keys.check_name(rig)
    prefix = f"{keys.PREFIX}/{rig}"
    health = [f"{prefix}/health/**"]
    rules = [
        _allow(
            "read-health", ["liveliness_query", "declare_liveliness_subscriber"], "ingress", health
        ),
        _allow("see-health", ["liveliness_token", "reply"], "egress", health),
    ]
    subjects: list[dict[str, Any]] = []
    policies: list[dict[str, Any]] = []
    for identity, (publishes, subscribes) in ROLES.items():
        own = [*(_key_expr(prefix, key) for key in publishes), f"{prefix}/stats/{identity}/*"]
        reads = [_key_expr(prefix, key) for key in subscribes]
        mine: list[dict[str, Any]] = []
        if identity != "observer":  # observers only look
            token = [f"{prefix}/health/{identity}/*"]
            mine += [
                _allow(f"{identity}-announce", ["liveliness_token"], "ingress", token),
                _allow(f"{identity}-publish", ["put"], "ingress", own),
                # A client's publisher sends only while the router tells it of a subscriber.
                _allow(f"{identity}-see-subscribers", ["declare_subscriber"], "egress", own),
            ]
        mine += [
            _allow(f"{identity}-subscribe", ["declare_subscriber"], "ingress", reads),
            _allow(f"{identity}-receive", ["put"], "egress", reads),
        ]
        rules += mine
        names = [rule["id"] for rule in mine]
        subjects.append({"id": identity, "cert_common_names": [identity]})
        policies.append(
            {"id": identity, "rules": ["read-health", "see-health", *names], "subjects": [identity]}
        )
    return {
        "enabled": True,
        "default_permission": "deny",
        "rules": rules,
        "subjects": subjects,
        "policies": policies,
    }


def _transport(tls: dict[str, Any]) -> dict[str, Any]:
    return {
        "link": {
            "tls": tls,
            "tx": {"lease": LINK_TUNING["lease"], "keep_alive": LINK_TUNING["keep_alive"]},
        },
        "unicast": {
            "open_timeout": LINK_TUNING["open_timeout"],
            "accept_timeout": LINK_TUNING["open_timeout"],
        },
    }


def router_config(rig: str, certs: CertPaths, listen: list[str]) -> dict[str, Any]:
    """The router of a secured rig: TLS only, client certificates required, access control."""
    _check_tls(listen, "--listen")
    return {
        "mode": "router",
        "listen": {"endpoints": list(listen)},
        "scouting": {"multicast": {"enabled": False}, "gossip": {"enabled": False}},
        "adminspace": {"enabled": True},
        "transport": _transport(
            {
                "root_ca_certificate": certs.ca(),
                "listen_certificate": certs.cert("router"),
                "listen_private_key": certs.key("router"),
                "enable_mtls": True,
                "close_link_on_expiration": True,
            }
        ),
        "access_control": access_control(rig),
    }


def service_config(identity: str, certs: CertPaths, connect: list[str]) -> dict[str, Any]:
    """A client of a secured rig with ``identity``'s certificate; checks the router's name."""
    if identity not in ROLES:
        raise SecureConfigError(f"unknown identity {identity!r}; use one of {', '.join(ROLES)}")
    _check_tls(connect, "--connect")
    return {
        "mode": "client",
        "connect": {
            "endpoints": list(connect),
            "timeout_ms": -1,
            "exit_on_failure": False,
            "retry": LINK_TUNING["retry"],
        },
        "scouting": {"multicast": {"enabled": False}, "gossip": {"enabled": False}},
        "transport": _transport(
            {
                "root_ca_certificate": certs.ca(),
                "connect_certificate": certs.cert(identity),
                "connect_private_key": certs.key(identity),
                "enable_mtls": True,
                "verify_name_on_connect": True,
                "close_link_on_expiration": True,
            }
        ),
    }


def _check_tls(endpoints: list[str], option: str) -> None:
    if not endpoints:
        raise SecureConfigError(f"{option} needs at least one endpoint")
    for endpoint in endpoints:
        if not endpoint.startswith("tls/"):
            raise SecureConfigError(
                f"{option} {endpoint!r}: a secured rig uses tls/HOST:PORT endpoints only"
            )


def render(config: dict[str, Any], about: str) -> str:
    """A config as a JSON5 file (JSON with a comment header), ready for ``--zenoh-config``."""
    header = "".join(f"// {line}\n".replace("// \n", "//\n") for line in about.splitlines())
    return header + json.dumps(config, indent=2) + "\n"


def rig_configs(
    rig: str, certs: CertPaths, *, connect: list[str], listen: list[str]
) -> dict[str, str]:
    """Every config file of a secured rig, by file name: the router's and one per identity."""
    files = {
        "router.json5": render(
            router_config(rig, certs, listen),
            f"Zenoh router of the secured rig {rig!r}: mutual TLS, access control.\n"
            f"facesynth router --zenoh-config router.json5\n"
            f"Generated by `facesynth certs`; certificates in {certs.folder}.",
        )
    }
    for identity in ROLES:
        use = (
            "facesynth status|health --zenoh-config observer.json5"
            if identity == "observer"
            else f"facesynth {identity} --zenoh-config {identity}.json5 ..."
        )
        files[f"{identity}.json5"] = render(
            service_config(identity, certs, connect),
            f"A {identity} client of the secured rig {rig!r} (certificate CN={identity}).\n"
            f"{use}\nGenerated by `facesynth certs`; certificates in {certs.folder}.",
        )
    return files
