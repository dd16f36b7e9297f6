"""Zenoh access control for a cell, derived from the key map (``catalog.ROUTES``).

Default deny. Each identity may do exactly what its role's routes list, on its own cell's keys:
an interpolator only on its own group's keys, every service only its own liveliness token and
info queryable. Observers receive and ask services who they are; operators may also inject
faults. Nothing else is written here: change a route in the catalogue and the ACL follows.

How Zenoh applies it (as measured on this project's machines): the router filters each
message per connection, ``ingress`` as it arrives from a client and ``egress`` as it leaves
towards one; a denied message is dropped silently.

Who a session is: its Zenoh username, and with mutual TLS also its certificate's common name.
Both are the identity's ``<cell>.<name>``, and a subject lists both, which Zenoh matches only
when each kind matches: a password with another identity's certificate, or either alone, is
no one. Without mutual TLS (a password-only bus, a TLS bus without client certificates) a
session has no common name, so there the subject is the username alone.

A site's router serves several cells (``access_control`` of every cell's parties): each cell's
identities keep their own cell's keys, a site observer watches every cell, and the routers of
a mesh pass each other everything, each having filtered its own clients.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import Any

from motocell.shared.bus.catalog import ROUTES, Op, Role, Route
from motocell.shared.bus.keys import ALIVE_ROOT, ROOT

INGRESS, EGRESS = "ingress", "egress"

# What a sender and a receiver of each kind of route need, as (flow, message kinds).
SENDING: dict[Op, tuple[tuple[str, tuple[str, ...]], ...]] = {
    Op.PUT: ((INGRESS, ("put",)),),
    Op.QUERY: ((INGRESS, ("query",)), (EGRESS, ("reply",))),
    Op.TOKEN: ((INGRESS, ("liveliness_token",)),),
}
RECEIVING: dict[Op, tuple[tuple[str, tuple[str, ...]], ...]] = {
    Op.PUT: ((INGRESS, ("declare_subscriber",)), (EGRESS, ("put",))),
    Op.QUERY: ((INGRESS, ("declare_queryable", "reply")), (EGRESS, ("query",))),
    Op.TOKEN: (
        (INGRESS, ("declare_liveliness_subscriber", "liveliness_query")),
        (EGRESS, ("liveliness_token", "reply")),
    ),
}
ANY_CELL = "*"
"""The cell level of a key expression that matches every cell."""
SITE_OBSERVER = "site.observer"
"""The site observer's username and certificate common name: it watches every cell."""
SITE_ROUTER = "site.router"
"""What a router of a site's mesh logs in as to the others."""
ROUTER_SUFFIX = ".router"
"""How every router's name ends: its certificate's common name (``<cell>.router``) and
SITE_ROUTER. No client identity may be named so: a client certificate with a router's name
would pass for that router where it is known by its certificate alone."""
MESSAGES = (
    ("put", "delete", "declare_subscriber"),
    ("query", "reply", "declare_queryable"),
    ("liveliness_token", "declare_liveliness_subscriber", "liveliness_query"),
)
"""Every message kind Zenoh's access control knows."""
DECLARATIONS = ("declare_subscriber", "declare_queryable", "declare_liveliness_subscriber")
"""Told to every identity of the cell: a publisher or querier learns that someone listens (and
routes to it) only from these. They carry key expressions, never data."""

Rule = tuple[str, tuple[str, ...], str]
"""(flow, message kinds, key expression): one allow rule."""


@dataclass(frozen=True)
class Identity:
    """One party on a cell's bus: a service instance (``interpolator`` ``2``) or a tool."""

    role: Role
    instance: str = "0"

    @property
    def name(self) -> str:
        """``gateway``, ``interpolator-2``: unique within a cell."""
        return self.role.value if self.instance == "0" else f"{self.role.value}-{self.instance}"

    def username(self, cell: str) -> str:
        return f"{cell}.{self.name}"


def cell_identities(groups: int, *, face: bool = False) -> list[Identity]:
    """Every identity a cell with ``groups`` control groups has, the ROS 2 face's with
    ``face`` (a cell file with ``[ros2]``)."""
    services = [
        Identity(Role.CONTROLLER),
        Identity(Role.EXECUTOR),
        Identity(Role.BROADCASTER),
        Identity(Role.GATEWAY),
        *(Identity(Role.INTERPOLATOR, str(group)) for group in range(groups)),
        *([Identity(Role.ROS2)] if face else []),
    ]
    return [*services, Identity(Role.OPERATOR), Identity(Role.OBSERVER)]


def own_keys(route: Route, cell: str, identity: Identity, sending: bool, groups: int) -> list[str]:
    """The concrete key expression(s) of ``route`` that ``identity`` acts on, in a cell of
    ``groups`` groups.

    A group's keys belong to that group's interpolator; anyone else sends on each group's key
    one by one (``group/0/point`` .. ``group/<groups-1>/point``), never on ``group/*/point``:
    the router itself refuses a put, query or token whose key has a ``*`` where a group goes,
    so no subscriber ever reads a group out of one. A service's token and info queryable are
    its own. Everyone else acts on the route's whole wildcard.
    """
    root = ALIVE_ROOT if route.op is Op.TOKEN else ROOT
    levels = route.suffix.split("/")
    if levels[0] == "group" and identity.role is Role.INTERPOLATOR:
        levels[1] = identity.instance
    elif levels[0] == "group" and sending:
        return [f"{root}/{cell}/group/{group}/{'/'.join(levels[2:])}" for group in range(groups)]
    declares_itself = (route.op is Op.TOKEN and sending) or (route.op is Op.QUERY and not sending)
    if levels[0] in ("alive", "claim", "service") and declares_itself:
        # A service declares its own liveliness token, name claim and info queryable only.
        levels[1:3] = [identity.role.value, identity.instance]
    return [f"{root}/{cell}/{'/'.join(levels)}"]


def _rules_for(cell: str, identity: Identity, groups: int) -> Iterator[Rule]:
    for route in ROUTES:
        if identity.role in route.senders:
            for flow, messages in SENDING[route.op]:
                for key in own_keys(route, cell, identity, sending=True, groups=groups):
                    yield flow, messages, key
        if identity.role in route.receivers:
            yield from _receiving(route, cell, identity, groups)
    yield from _whole_cell(cell, identity)
    for root in (ROOT, ALIVE_ROOT):
        yield EGRESS, DECLARATIONS, f"{root}/{cell}/**"


def _receiving(route: Route, cell: str, identity: Identity, groups: int) -> Iterator[Rule]:
    """A receiver declares (and replies) on its own keys, but a query reaches it on the key
    the querier asked: a wildcard query (``service/*/*``) must be let out to every server."""
    wildcard = f"{ALIVE_ROOT if route.op is Op.TOKEN else ROOT}/{cell}/{route.suffix}"
    for flow, messages in RECEIVING[route.op]:
        if route.op is Op.QUERY and flow == EGRESS:
            yield flow, messages, wildcard
        else:
            for key in own_keys(route, cell, identity, sending=False, groups=groups):
                yield flow, messages, key


def _whole_cell(cell: str, identity: Identity) -> Iterator[Rule]:
    """A role that receives every route of a kind may subscribe to the whole cell at once: a
    ``motocell/<cell>/**`` subscriber (an observer's) is checked against the whole expression,
    and would be refused if only the single keys were allowed."""
    for op, root in ((Op.PUT, ROOT), (Op.TOKEN, ALIVE_ROOT)):
        routes = [route for route in ROUTES if route.op is op]
        if all(identity.role in route.receivers for route in routes):
            for flow, messages in RECEIVING[op]:
                yield flow, messages, f"{root}/{cell}/**"


@dataclass(frozen=True)
class Party:
    """One subject of a router's access control: a Zenoh username (and with mutual TLS the
    certificate common name, the same text) and what it may do."""

    name: str
    rules: tuple[Rule, ...]
    certificate_only: bool = False
    """Known by its certificate alone: a router this one connected to, whose server
    certificate is all it shows (it logs in to no one)."""


def cell_parties(cell: str, identities: Iterable[Identity]) -> list[Party]:
    """``identities`` of ``cell``, each allowed what its role's routes list. The cell's groups
    are those of its interpolators (``cell_identities``)."""
    identities = list(identities)
    groups = sum(identity.role is Role.INTERPOLATOR for identity in identities)
    return [
        Party(identity.username(cell), tuple(_rules_for(cell, identity, groups)))
        for identity in identities
    ]


def site_observer(name: str) -> Party:
    """An observer of every cell the router carries (``ps``, ``watch``, ``record``): what a
    cell's observer may, with any cell's name. It acts on nothing."""
    return Party(name, tuple(_rules_for(ANY_CELL, Identity(Role.OBSERVER), groups=0)))


def is_router_name(user: str) -> bool:
    """Whether ``user`` is named like a router (ROUTER_SUFFIX): never a client's name."""
    return user.endswith(ROUTER_SUFFIX)


def router_links(name: str, dialed: str | None) -> list[Party]:
    """Another router of the site's mesh: every message both ways on every cell's keys. Each
    router filters its own clients by the same rules, so what a router passes on was allowed
    where it came in. A router that connected here logs in as ``name`` with its password and
    client certificate, both required. A router this one dials logs in to no one (Zenoh
    checks a password only of the side that dials): it shows only its server certificate,
    whose common name is ``dialed``. That subject is the one a certificate alone matches, so
    only a router that dials others has it (``dialed`` None: it dials none), and no client
    certificate may carry a router's name (``is_router_name``)."""
    everything = tuple(kind for kinds in MESSAGES for kind in kinds)
    rules = tuple(
        (flow, everything, f"{root}/**")
        for flow in (INGRESS, EGRESS)
        for root in (ROOT, ALIVE_ROOT)
    )
    links = [Party(name, rules)]
    if dialed is not None:
        links.append(Party(dialed, rules, certificate_only=True))
    return links


def _by_kind(rules: Iterable[Rule]) -> dict[tuple[str, tuple[str, ...]], list[str]]:
    """``rules`` as one rule per flow and message kinds, with every key expression they allow
    in the order they came, each once: the same permissions in a third as many rules, which
    Zenoh reads from the router's config (JSON5, 6-9 ms of CPU at 213 rules for a single-arm
    cell) in a third of the time, at every cell's start (docs/startup.md)."""
    merged: dict[tuple[str, tuple[str, ...]], list[str]] = {}
    for flow, messages, key in rules:
        keys = merged.setdefault((flow, messages), [])
        if key not in keys:
            keys.append(key)
    return merged


def access_control(parties: Iterable[Party], *, certificates: bool) -> dict[str, Any]:
    """The ``access_control`` section of a router's Zenoh config. ``certificates``: clients
    present certificates (mutual TLS), and each subject must match both name and certificate."""
    rules: list[dict[str, Any]] = []
    subjects: list[dict[str, Any]] = []
    policies: list[dict[str, Any]] = []
    for party in parties:
        subject: dict[str, Any] = {"id": party.name}
        if not party.certificate_only:
            subject["usernames"] = [party.name]
        if certificates:
            subject["cert_common_names"] = [party.name]
        subjects.append(subject)
        ids = []
        for index, ((flow, messages), keys) in enumerate(_by_kind(party.rules).items()):
            rule_id = f"{party.name}#{index}"
            ids.append(rule_id)
            rules.append(
                {
                    "id": rule_id,
                    "permission": "allow",
                    "flows": [flow],
                    "messages": list(messages),
                    "key_exprs": keys,
                }
            )
        policies.append({"id": party.name, "subjects": [party.name], "rules": ids})
    return {
        "enabled": True,
        "default_permission": "deny",
        "rules": rules,
        "subjects": subjects,
        "policies": policies,
    }
