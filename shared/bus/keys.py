"""Zenoh key expressions of a cell. Everything lives under ``motocell/<cell>/``; entity kinds
and ids sit at fixed positions so ``*`` selects one level, and no key carries a sequence
number or a timestamp (those travel in the payload). docs/payloads.md lists every key.
"""

from __future__ import annotations

ROOT = "motocell"
ALIVE_ROOT = "@motocell"
"""Liveliness tokens start with '@' so a plain ``**`` data subscriber does not see them."""


class CellKeys:
    def __init__(self, cell: str) -> None:
        self.cell = cell
        self.prefix = f"{ROOT}/{cell}"
        self.controller_status = f"{self.prefix}/controller/status"
        self.executor_tick = f"{self.prefix}/executor/tick"
        self.executor_late = f"{self.prefix}/executor/late"
        self.state = f"{self.prefix}/state"
        self.group_slot_all = f"{self.prefix}/group/*/slot"
        self.group_point_all = f"{self.prefix}/group/*/point"
        self.alive_all = f"{ALIVE_ROOT}/{cell}/alive/*/*"

    def controller_cmd(self, verb: str) -> str:
        return f"{self.prefix}/controller/cmd/{verb}"

    def controller_fault(self, kind: str) -> str:
        return f"{self.prefix}/controller/fault/{kind}"

    def executor_cmd(self, verb: str) -> str:
        return f"{self.prefix}/executor/cmd/{verb}"

    def gateway_cmd(self, verb: str) -> str:
        return f"{self.prefix}/gateway/cmd/{verb}"

    def broadcaster_cmd(self, verb: str) -> str:
        return f"{self.prefix}/broadcaster/cmd/{verb}"

    def group_point(self, group: int) -> str:
        return f"{self.prefix}/group/{group}/point"

    def group_slot(self, group: int) -> str:
        return f"{self.prefix}/group/{group}/slot"

    def group_increments(self, group: int) -> str:
        return f"{self.prefix}/group/{group}/increments"

    def group_queue(self, group: int) -> str:
        return f"{self.prefix}/group/{group}/queue"

    def service_info(self, service: str, instance: str) -> str:
        return f"{self.prefix}/service/{service}/{instance}"

    def metrics(self, service: str) -> str:
        return f"{self.prefix}/{service}/metrics"

    def group_metrics(self, group: int) -> str:
        return f"{self.prefix}/group/{group}/metrics"

    def claim(self, service: str, instance: str, session_id: str) -> str:
        """A service instance's claim to its name, one per session (see shared.bus.claim)."""
        return f"{ALIVE_ROOT}/{self.cell}/claim/{service}/{instance}/{session_id}"

    def claims(self, service: str, instance: str) -> str:
        return f"{ALIVE_ROOT}/{self.cell}/claim/{service}/{instance}/*"

    def alive(self, service: str, instance: str) -> str:
        return f"{ALIVE_ROOT}/{self.cell}/alive/{service}/{instance}"


def service_of_alive(key: str) -> str:
    """``@motocell/<cell>/alive/<service>/<instance>`` -> ``<service>/<instance>``."""
    parts = key.split("/")
    return "/".join(parts[3:5])


def group_of(key: object, groups: int) -> int | None:
    """``motocell/<cell>/group/<g>/...`` -> g, when g is one of the cell's ``groups`` written
    as ``group_point`` and its kin write it; None for anything else: a ``*`` chunk, a sign,
    a leading zero, a group the cell does not have, a key that is no group's. Anyone allowed
    to write a group's key may send any of these; none may be taken for a group."""
    parts = str(key).split("/")
    if len(parts) < 5 or parts[2] != "group":
        return None
    chunk = parts[3]
    if not (chunk.isascii() and chunk.isdigit()) or (len(chunk) > 1 and chunk[0] == "0"):
        return None
    if len(chunk) > len(str(groups)):  # bounds int()'s work on a chunk of a million digits
        return None
    group = int(chunk)
    return group if group < groups else None
