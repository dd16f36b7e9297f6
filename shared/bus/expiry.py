"""When the certificates of a credentials directory end, read without a TLS library: ``ps``
and ``watch`` warn before a bus starts refusing its parties, and must stay light (no
``cryptography``, no ``ssl``). A certificate's end is one field at a fixed place of its DER
encoding (RFC 5280, section 4.1: the second time of ``validity``, after the version, serial
number, signature algorithm and issuer), so a few lines read it.
"""

from __future__ import annotations

import base64
import datetime
from collections.abc import Iterable
from pathlib import Path

from motocell.shared.files import SECRET_LIMIT, read_bounded

WARN_WITHIN = datetime.timedelta(days=30)
"""How long before its end a certificate is warned about; what ``--renew`` renews by
default."""
_BEGIN, _END = b"-----BEGIN CERTIFICATE-----", b"-----END CERTIFICATE-----"
_UTC_TIME, _GENERALIZED_TIME, _VERSION = 0x17, 0x18, 0xA0


def not_after(pem: bytes) -> datetime.datetime:
    """The end of validity of the first certificate in ``pem``; ValueError if there is
    none."""
    try:
        body = pem[pem.index(_BEGIN) + len(_BEGIN) : pem.index(_END)]
        der = base64.b64decode(b"".join(body.split()), validate=True)
        _, certificate, _ = _element(der, 0)
        _, field, _ = _element(der, certificate)  # the signed part's first field
        tag, _, end = _element(der, field)
        field = end if tag == _VERSION else field
        for _ in range(3):  # serial number, signature algorithm, issuer
            field = _element(der, field)[2]
        _, validity, _ = _element(der, field)
        tag, start, end = _element(der, _element(der, validity)[2])
        text = der[start:end].decode("ascii")
    except (ValueError, IndexError) as exc:
        raise ValueError(f"not a PEM certificate: {exc}") from None
    layout = {_UTC_TIME: "%y%m%d%H%M%SZ", _GENERALIZED_TIME: "%Y%m%d%H%M%SZ"}.get(tag)
    if layout is None:
        raise ValueError("not a PEM certificate: its end of validity is not a time")
    return datetime.datetime.strptime(text, layout).replace(tzinfo=datetime.UTC)


def _element(der: bytes, at: int) -> tuple[int, int, int]:
    """The DER element at ``at``: its tag, and where its contents start and end."""
    tag, length, start = der[at], der[at + 1], at + 2
    if length & 0x80:
        size = length & 0x7F
        length, start = int.from_bytes(der[start : start + size], "big"), start + size
    if start + length > len(der):
        raise ValueError("truncated")
    return tag, start, start + length


def expiring(
    directory: Path, now: datetime.datetime, within: datetime.timedelta = WARN_WITHIN
) -> list[tuple[str, datetime.datetime]]:
    """The certificates of ``directory`` that end within ``within`` of ``now`` (or already
    have), soonest first, by file name. Files that are no certificate are not counted: TLS
    refuses them with its own words."""
    ends = []
    for path in directory.glob("*.pem"):
        try:
            ends.append((path.name, not_after(read_bounded(path, SECRET_LIMIT))))
        except (OSError, ValueError):
            continue
    return sorted(((name, end) for name, end in ends if end - now <= within), key=lambda e: e[1])


def warnings(directories: Iterable[Path], now: datetime.datetime) -> list[str]:
    """One line per credentials directory whose certificates end within ``WARN_WITHIN``."""
    lines = []
    for directory in dict.fromkeys(directories):
        soon = expiring(directory, now)
        if soon:
            ends = ", ".join(
                f"{name} {'expired' if end <= now else 'expires'} {end:%Y-%m-%d %H:%M} UTC"
                for name, end in soon
            )
            lines.append(
                f"certificates of {directory} end within {WARN_WITHIN.days} days: {ends}; "
                "renew them (`motocell credentials DIR --renew` in the directory they were "
                "made in) and give each party its new bundle"
            )
    return lines
