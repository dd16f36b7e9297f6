"""The Zenoh router's settings, as one nested dict: the launcher's own router, the compose
file's zenohd router and a site's routers for many cells (``tools.site``) are all made from
it, so they cannot drift apart.

Secured (the default): password authentication against the cell's user dictionary, the access
control of ``shared.bus.access``, and with TLS a TLS-only listener (mutual TLS when the
credentials directory has per-identity certificates). Always: no multicast scouting, no gossip
(a router must not tell clients where other nodes listen), no admin space (it would show every
session's address to any client).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import zenoh

from motocell.shared.bus.access import Identity, Party, access_control, cell_parties
from motocell.shared.bus.credentials import CA_FILE, USERS_FILE, Credentials
from motocell.shared.bus.session import LEASE_MS, SHARED_MEMORY

ROUTER_CERTIFICATE, ROUTER_KEY = "router.pem", "router.key"
MAX_SESSIONS = 10_000
"""Sessions a router admits at once. Zenoh's default, 1000, is 166 single-arm cells on one
router (six sessions each: five services and the launcher; docs/benchmarks.md, figure 15); a
site's router is bounded by its open-files limit instead (``motocell router`` raises its own
to the hard limit, one descriptor per session)."""


def router_settings(
    listen: Sequence[str],
    connect: Sequence[str] = (),
    *,
    cell: str | None = None,
    identities: Sequence[Identity] = (),
    credentials: Path | None = None,
    mutual_tls: bool = False,
) -> dict[str, Any]:
    """One cell's router. ``cell`` and ``credentials`` secure it; without them the bus is open
    (a trusted lab)."""
    if cell is None or credentials is None:
        return _open_settings(listen, connect)
    return secured_settings(
        listen, connect, cell_parties(cell, identities), credentials, mutual_tls=mutual_tls
    )


def secured_settings(
    listen: Sequence[str],
    connect: Sequence[str],
    parties: Sequence[Party],
    credentials: Path,
    *,
    mutual_tls: bool,
    link: Credentials | None = None,
) -> dict[str, Any]:
    """A router that admits only ``parties``, each to what it may do: passwords from
    ``credentials``'s user dictionary, and on a TLS listener its CA and router certificate.
    With ``mutual_tls`` a party is its username and its certificate together. ``link``: what
    this router presents to the routers it ``connect``s to (a site's mesh)."""
    settings = _open_settings(listen, connect)
    usrpwd: dict[str, str] = {"dictionary_file": str(credentials / USERS_FILE)}
    if link is not None:
        usrpwd |= {"user": link.user, "password": link.password}
    settings["transport"]["auth"] = {"usrpwd": usrpwd}
    settings["access_control"] = access_control(parties, certificates=mutual_tls)
    if any(endpoint.startswith("tls/") for endpoint in [*listen, *connect]):
        settings["transport"]["link"]["protocols"] = ["tls"]
        tls = {
            "root_ca_certificate": str(credentials / CA_FILE),
            "listen_certificate": str(credentials / ROUTER_CERTIFICATE),
            "listen_private_key": str(credentials / ROUTER_KEY),
            "enable_mtls": mutual_tls,
        }
        if link is not None and link.certificate is not None and link.key is not None:
            tls |= {
                "connect_certificate": str(link.certificate),
                "connect_private_key": str(link.key),
            }
        settings["transport"]["link"]["tls"] = tls
    return settings


def _open_settings(listen: Sequence[str], connect: Sequence[str]) -> dict[str, Any]:
    return {
        "mode": "router",
        "listen": {"endpoints": list(listen)},
        "connect": {"endpoints": list(connect)},
        # No scouting, so nothing to wait for: Zenoh's default delay holds every router's
        # start for 500 ms, a third of a cell's start-up.
        "scouting": {
            "delay": 0,
            "multicast": {"enabled": False},
            "gossip": {"enabled": False},
        },
        "adminspace": {"enabled": False},
        "transport": {
            "link": {"tx": {"lease": LEASE_MS}},
            "shared_memory": {"enabled": SHARED_MEMORY},
            "unicast": {"max_sessions": MAX_SESSIONS},
        },
    }


def zenoh_config(settings: dict[str, Any]) -> zenoh.Config:
    """``settings`` as a Zenoh config; Zenoh refuses an unknown field or a bad value here."""
    config = zenoh.Config()
    for key, value in settings.items():
        config.insert_json5(key, json.dumps(value))
    return config
