"""Why a router that accepts TCP refused a session, when the cause is TLS: Zenoh reports every
refusal with the same words ("Unable to connect"), so a refused session is probed again with
the standard library's TLS, with the same CA, host name and certificate Zenoh was given.

- a ``tls/`` endpoint: the router's certificate fails our check (another CA, not valid for
  the name dialled, expired), or the router refuses ours during the handshake (none given,
  another CA, expired; it says so in a TLS alert just after the handshake);
- a ``tcp/`` endpoint, with credentials made for TLS: the router speaks TLS.

None when TLS is not the cause: the router then refused the Zenoh login itself (a wrong
password, or a user it does not know). Only ever called once a session was refused, so its
``ssl`` import and its probe cost nothing to a session that opens.
"""

from __future__ import annotations

import socket
import ssl

from motocell.shared.bus.credentials import Credentials

PROBE_S = 2.0
"""How long the probe waits for the router: an alert refusing a client certificate came within
0.01 s on an idle machine, but more than 0.5 s with three test runs on two busy cores; a router
that accepted the certificate says nothing at all until the client's Zenoh handshake, so a
wrong password over TLS is told this much later."""
HOSTNAME_MISMATCH = 62
CERTIFICATE_EXPIRED = 10
"""OpenSSL's verification codes (``X509_V_ERR_HOSTNAME_MISMATCH``, ``..._CERT_HAS_EXPIRED``)."""
RENEW = "`motocell credentials DIR --renew` where the credentials were made"


def tls_problem(endpoint: str, credentials: Credentials | None) -> str | None:
    """One line on what is wrong at the TLS layer between us and ``endpoint``, or None."""
    protocol, _, address = endpoint.partition("/")
    host, _, port_text = address.rpartition(":")
    host = host.strip("[]")
    if not port_text.isdigit():
        return None
    port = int(port_text)
    if protocol == "tcp":
        # Only with TLS credentials in hand: a password-only refusal (a local cell's) is not
        # held up by a probe that would wait PROBE_S on a router speaking plain TCP.
        has_tls = credentials is not None and credentials.ca is not None
        return _speaks_tls(endpoint, host, port) if has_tls else None
    if protocol != "tls":
        return None
    try:
        context = _client_context(credentials)
    except (OSError, ssl.SSLError) as exc:
        return f"the TLS files of {_who(credentials)} cannot be used: {exc}"
    return _handshake_problem(endpoint, host, port, context, credentials)


def _client_context(credentials: Credentials | None) -> ssl.SSLContext:
    """What Zenoh was given: the CA to check the router against, our certificate."""
    context = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
    if credentials is not None and credentials.ca is not None:
        context.load_verify_locations(credentials.ca)
    else:
        context.load_default_certs()
    if credentials is not None and credentials.certificate and credentials.key:
        context.load_cert_chain(credentials.certificate, credentials.key)
    return context


def _handshake_problem(
    endpoint: str, host: str, port: int, context: ssl.SSLContext, credentials: Credentials | None
) -> str | None:
    try:
        with (
            socket.create_connection((host, port), timeout=PROBE_S) as raw,
            context.wrap_socket(raw, server_hostname=host) as tls,
        ):
            try:
                tls.recv(1)
            except ssl.SSLError as exc:
                return _our_certificate_refused(endpoint, exc, credentials)
            except TimeoutError:
                return None  # the router took our certificate: it refused the login
    except ssl.SSLCertVerificationError as exc:
        return _router_certificate_problem(endpoint, host, exc, credentials)
    except TimeoutError:
        return (
            f"the router at {endpoint} does not answer a TLS handshake: if it speaks plain "
            f"TCP, connect to tcp/{host}:{port}"
        )
    except (ssl.SSLError, OSError):
        return None
    return None


def _router_certificate_problem(
    endpoint: str, host: str, error: ssl.SSLCertVerificationError, credentials: Credentials | None
) -> str:
    if error.verify_code == HOSTNAME_MISMATCH:
        return (
            f"the router's TLS certificate at {endpoint} is not valid for the name {host}: "
            "dial a name or address it was made for, or add this one with `motocell "
            f"credentials DIR --host {host}` and restart the router with its new bundle"
        )
    if error.verify_code == CERTIFICATE_EXPIRED:
        return (
            f"the router's TLS certificate at {endpoint} has expired: renew it ({RENEW}) and "
            "restart the router with its new bundle"
        )
    ca = credentials.ca if credentials is not None and credentials.ca else "the system's CAs"
    return (
        f"the router's TLS certificate at {endpoint} is not from the CA in {ca} "
        f"({error.verify_message}): use the bundle made with the router's, from the same "
        "credentials directory"
    )


def _our_certificate_refused(
    endpoint: str, alert: ssl.SSLError, credentials: Credentials | None
) -> str:
    reason = str(alert.reason or alert)
    who = _who(credentials)
    if "CERTIFICATE_REQUIRED" in reason:
        return (
            f"the router at {endpoint} refused {who}: it requires a client certificate (mutual "
            "TLS) and was given none; give the identity's bundle, with its USER.pem and USER.key"
        )
    if "CERTIFICATE_EXPIRED" in reason:
        return f"the router at {endpoint} refused {who}'s certificate: it has expired ({RENEW})"
    return (
        f"the router at {endpoint} refused {who}'s certificate ({reason}): it is not from the "
        "router's CA; use the bundle made in the router's credentials directory"
    )


def _speaks_tls(endpoint: str, host: str, port: int) -> str | None:
    context = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
    context.check_hostname = False
    context.verify_mode = ssl.CERT_NONE  # only asking whether it speaks TLS at all
    try:
        with (
            socket.create_connection((host, port), timeout=PROBE_S) as raw,
            context.wrap_socket(raw, server_hostname=host),
        ):
            pass
    except (ssl.SSLError, OSError):
        return None
    return (
        f"the router at {endpoint} speaks TLS: connect to tls/{host}:{port}, with credentials "
        "made with --tls"
    )


def _who(credentials: Credentials | None) -> str:
    return "this session" if credentials is None else credentials.user
