"""The face's thread: waits for the cell's next ``state`` sample or the face's next deadline,
hands either to ``core.face.Face``, and publishes what it returns (``Topics``). It decides
nothing itself."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Protocol

from motocell.services.ros2.core.face import Face
from motocell.services.ros2.core.topics import TopicValues
from motocell.shared.bus.channels import StopSignal
from motocell.shared.bus.schemas import ControllerStatus, State


class Samples(Protocol):
    def next(self, deadline_ns: int | None, samples_expected: bool) -> State | None:
        """The newest sample; None when woken at ``deadline_ns`` or at stop without one.
        ``samples_expected``: wake for a sample as it comes; else only at the deadline."""
        ...

    def controller_status(self) -> ControllerStatus | None:
        """The controller's newest status since the last call, if one came; never blocks."""
        ...


class Topics(Protocol):
    """MotoROS2's topics (``node.FaceNode``)."""

    def publish(self, values: TopicValues) -> None: ...

    def observed(self) -> bool:
        """Whether any subscription matches any topic now; a new one rings the samples'
        doorbell."""
        ...


class FaceLoop:
    def __init__(
        self,
        face: Face,
        samples: Samples,
        topics: Topics,
        monotonic_ns: Callable[[], int] = time.monotonic_ns,
    ) -> None:
        self.face = face
        self.samples = samples
        self.topics = topics
        self._monotonic_ns = monotonic_ns

    def run(self, stop: StopSignal) -> None:
        face = self.face
        while not stop.is_set():
            # Nobody reads: no wake-up for the period. A sample (once a second at rest) or a
            # new reader's doorbell wakes the loop, and the face publishes from then on.
            deadline_ns = face.wake_ns if self.topics.observed() else None
            state = self.samples.next(deadline_ns, face.samples_expected)
            now_ns = self._monotonic_ns()
            status = self.samples.controller_status()
            if status is not None:
                face.on_status(status, now_ns)
            values = face.on_wake(now_ns) if state is None else face.on_sample(state, now_ns)
            if values is not None:
                self.topics.publish(values)
