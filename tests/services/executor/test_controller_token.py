"""The executor follows the controller's token from its clock thread, over a real router: present
if it was there before, gone on its DELETE, present again when a new controller declares it."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from motocell.services.executor.controller_token import ASK_EVERY_NS, ControllerToken
from motocell.shared.bus.session import open_session
from motocell.shared.ports import free_port
from motocell.testing.processes import wait_until

TOKEN = "@motocell/c/alive/controller/0"


@pytest.fixture
def router() -> Iterator[str]:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    session = open_session("router", listen=[endpoint], wait=False)
    yield endpoint
    session.close()


class Clock:
    """The executor's looks at the token, each at a time that steps past the re-ask period, so
    every look while the controller is absent asks again."""

    def __init__(self, watch: ControllerToken) -> None:
        self.watch = watch
        self.now_ns = 0

    def present(self) -> bool:
        self.now_ns += ASK_EVERY_NS
        return self.watch.present(self.now_ns)


def test_the_controller_token_over_a_router(router: str) -> None:
    executor = open_session("client", [router], wait=False)
    first = open_session("client", [router], wait=False)
    second = open_session("client", [router], wait=False)
    try:
        tokens = [first.liveliness().declare_token(TOKEN)]  # a token lives while referenced
        clock = Clock(ControllerToken(executor, TOKEN))
        wait_until(clock.present, 5.0, "the token declared before")

        first.close()
        wait_until(lambda: not clock.present(), 5.0, "the DELETE of a closed session")

        tokens.append(second.liveliness().declare_token(TOKEN))
        wait_until(clock.present, 5.0, "a new controller's token")
    finally:
        for session in (second, first, executor):
            session.close()
