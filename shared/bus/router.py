"""The Zenoh router's settings for a cell, as one nested dict: the launcher's own router and
the compose file's zenohd router are both made from it, so the two cannot drift apart.

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

from motocell.shared.bus.access import Identity, access_control
from motocell.shared.bus.credentials import CA_FILE, USERS_FILE
from motocell.shared.bus.session import LEASE_MS

ROUTER_CERTIFICATE, ROUTER_KEY = "router.pem", "router.key"


def router_settings(
    listen: Sequence[str],
    connect: Sequence[str] = (),
    *,
    cell: str | None = None,
    identities: Sequence[Identity] = (),
    credentials: Path | None = None,
    mutual_tls: bool = False,
) -> dict[str, Any]:
    """``cell`` and ``credentials`` secure it; without them the bus is open (a trusted lab)."""
    settings: dict[str, Any] = {
        "mode": "router",
        "listen": {"endpoints": list(listen)},
        "connect": {"endpoints": list(connect)},
        # No scouting, so nothing to wait for: Zenoh's default delay held every router's
        # start for 500 ms, a third of a cell's start-up.
        "scouting": {
            "delay": 0,
            "multicast": {"enabled": False},
            "gossip": {"enabled": False},
        },
        "adminspace": {"enabled": False},
        "transport": {"link": {"tx": {"lease": LEASE_MS}}},
    }
    if cell is None or credentials is None:
        return settings
    settings["transport"]["auth"] = {"usrpwd": {"dictionary_file": str(credentials / USERS_FILE)}}
    settings["access_control"] = access_control(cell, identities)
    if any(endpoint.startswith("tls/") for endpoint in listen):
        settings["transport"]["link"]["protocols"] = ["tls"]
        settings["transport"]["link"]["tls"] = {
            "root_ca_certificate": str(credentials / CA_FILE),
            "listen_certificate": str(credentials / ROUTER_CERTIFICATE),
            "listen_private_key": str(credentials / ROUTER_KEY),
            "enable_mtls": mutual_tls,
        }
    return settings


def zenoh_config(settings: dict[str, Any]) -> zenoh.Config:
    """``settings`` as a Zenoh config; Zenoh refuses an unknown field or a bad value here."""
    config = zenoh.Config()
    for key, value in settings.items():
        config.insert_json5(key, json.dumps(value))
    return config
