"""The managed-node lifecycle both hardware components and controllers go through.

Counterpart: ``rclcpp_lifecycle::LifecycleNode``'s state machine as ros2_control drives it
(hardware_interface::System::configure() etc., controller_manager's controller wrappers).
A transition runs its callback; SUCCESS moves on, FAILURE stays where it was, ERROR (or an
exception, kept in ``last_exception``) runs on_error: SUCCESS -> UNCONFIGURED, otherwise
FINALIZED (unrecoverable). ``impl`` is the object with the on_* callbacks.
"""

from __future__ import annotations

from dataclasses import dataclass

from .hardware.types import (
    ACTIVE,
    FINALIZED,
    INACTIVE,
    UNCONFIGURED,
    UNKNOWN,
    CallbackReturn,
    State,
)


def as_callback_return(result, who: str, what: str) -> CallbackReturn:
    try:
        return CallbackReturn(result)
    except ValueError:
        raise TypeError(f"{who}.{what}() returned {result!r}; return CallbackReturn.SUCCESS, "
                        "FAILURE or ERROR") from None


class LifecycleCallbacks:
    """The managed-node callbacks with their default (SUCCESS); components and controllers override them."""

    def on_configure(self, previous_state: State) -> CallbackReturn:
        return CallbackReturn.SUCCESS

    def on_cleanup(self, previous_state: State) -> CallbackReturn:
        return CallbackReturn.SUCCESS

    def on_shutdown(self, previous_state: State) -> CallbackReturn:
        return CallbackReturn.SUCCESS

    def on_activate(self, previous_state: State) -> CallbackReturn:
        return CallbackReturn.SUCCESS

    def on_deactivate(self, previous_state: State) -> CallbackReturn:
        return CallbackReturn.SUCCESS

    def on_error(self, previous_state: State) -> CallbackReturn:
        return CallbackReturn.SUCCESS


@dataclass(frozen=True)
class Transition:
    """One callback the state machine ran: from ``start`` via ``callback`` (its ``result``) to ``goal``."""

    start: str
    callback: str
    result: str
    goal: str


class Lifecycle:
    """Drives ``impl`` through UNCONFIGURED / INACTIVE / ACTIVE / FINALIZED.

    ``history`` lists every callback run, in order (:class:`Transition`): what a lifecycle
    node's ``transition_event`` topic reports, kept so a notebook can draw what happened.
    """

    def __init__(self, impl):
        self.impl = impl
        self.state: State = UNKNOWN
        self.last_exception: BaseException | None = None
        self.history: list[Transition] = []

    def _set(self, state: State) -> State:
        self.state = state
        self.impl._lifecycle_state = state
        return state

    def _call(self, what: str, *args) -> CallbackReturn:
        try:
            return as_callback_return(getattr(self.impl, what)(*args), type(self.impl).__name__, what)
        except Exception as exc:  # a callback that raises is an ERROR, like an uncaught C++ throw
            self.last_exception = exc
            return CallbackReturn.ERROR

    def _record(self, start: State, callback: str, result: CallbackReturn) -> None:
        self.history.append(Transition(start.label, callback, result.name, self.state.label))

    def initialize(self, *args, method: str = "on_init") -> State:
        """``impl.<method>(*args)`` (on_init, or a controller's init): SUCCESS -> UNCONFIGURED, else FINALIZED."""
        if self.state is not UNKNOWN:
            return self.state
        result = self._call(method, *args)
        self._set(UNCONFIGURED if result is CallbackReturn.SUCCESS else FINALIZED)
        self._record(UNKNOWN, method, result)
        return self.state

    def _transition(self, frm: State, callback: str, to: State) -> State:
        if self.state != frm:
            return self.state
        result = self._call(callback, self.state)
        if result is CallbackReturn.SUCCESS:
            self._set(to)
        self._record(frm, callback, result)
        if result is CallbackReturn.ERROR:
            return self.error()
        return self.state

    def configure(self) -> State:
        return self._transition(UNCONFIGURED, "on_configure", INACTIVE)

    def cleanup(self) -> State:
        return self._transition(INACTIVE, "on_cleanup", UNCONFIGURED)

    def activate(self) -> State:
        return self._transition(INACTIVE, "on_activate", ACTIVE)

    def deactivate(self) -> State:
        return self._transition(ACTIVE, "on_deactivate", INACTIVE)

    def shutdown(self) -> State:
        if self.state in (UNKNOWN, FINALIZED):
            return self.state
        start = self.state
        result = self._call("on_shutdown", self.state)
        if result is CallbackReturn.SUCCESS:
            self._set(FINALIZED)
        self._record(start, "on_shutdown", result)
        if result is CallbackReturn.ERROR:
            return self.error()
        return self.state

    def error(self) -> State:
        """on_error: SUCCESS -> UNCONFIGURED, FAILURE/ERROR -> FINALIZED (unrecoverable)."""
        if self.state in (UNKNOWN, FINALIZED):
            return self.state
        start = self.state
        result = self._call("on_error", self.state)
        self._set(UNCONFIGURED if result is CallbackReturn.SUCCESS else FINALIZED)
        self._record(start, "on_error", result)
        return self.state


__all__ = ["Lifecycle", "LifecycleCallbacks", "Transition", "as_callback_return"]
