"""Callback groups: which callbacks of a MultiThreadedExecutor may run at the same time.

rclpy counterparts: ``rclpy.callback_groups.MutuallyExclusiveCallbackGroup`` (the default
group of every node: its callbacks never overlap, even on many threads) and
``ReentrantCallbackGroup`` (its callbacks, and several runs of the same callback, may run in
parallel). A single-threaded executor runs one callback at a time whatever the group.
"""

from __future__ import annotations

import threading


class CallbackGroup:
    def __init__(self):
        self.entities = []

    def add_entity(self, entity) -> None:
        self.entities.append(entity)

    def has_entity(self, entity) -> bool:
        return entity in self.entities

    def can_execute(self, entity) -> bool:
        raise NotImplementedError

    def beginning_execution(self, entity) -> bool:
        raise NotImplementedError

    def ending_execution(self, entity) -> None:
        raise NotImplementedError


class ReentrantCallbackGroup(CallbackGroup):
    """Callbacks may run concurrently (with each other and with themselves)."""

    def can_execute(self, entity) -> bool:
        return True

    def beginning_execution(self, entity) -> bool:
        return True

    def ending_execution(self, entity) -> None:
        pass


class MutuallyExclusiveCallbackGroup(CallbackGroup):
    """At most one callback of the group runs at any time."""

    def __init__(self):
        super().__init__()
        self._active = None
        self._lock = threading.Lock()

    def can_execute(self, entity) -> bool:
        return self._active is None

    def beginning_execution(self, entity) -> bool:
        with self._lock:
            if self._active is None:
                self._active = entity
                return True
            return False

    def ending_execution(self, entity) -> None:
        with self._lock:
            self._active = None
