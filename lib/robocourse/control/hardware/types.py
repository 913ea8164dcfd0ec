"""Return codes and lifecycle states shared by hardware components and controllers.

Counterparts: ``hardware_interface::return_type`` (OK=0, ERROR=1, DEACTIVATE=2),
``rclcpp_lifecycle::node_interfaces::LifecycleNodeInterface::CallbackReturn`` (SUCCESS,
FAILURE, ERROR) and ``lifecycle_msgs/msg/State`` ids (UNKNOWN=0, UNCONFIGURED=1,
INACTIVE=2, ACTIVE=3, FINALIZED=4) with their lowercase labels.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum


class return_type(IntEnum):  # noqa: N801  (ros2_control's spelling)
    """What read()/write()/update() return: OK, ERROR, or (write only) DEACTIVATE."""

    OK = 0
    ERROR = 1
    DEACTIVATE = 2


class CallbackReturn(IntEnum):
    """What a lifecycle callback (on_configure, on_activate, ...) returns."""

    SUCCESS = 0
    FAILURE = 1
    ERROR = 2


@dataclass(frozen=True)
class State:
    """A lifecycle state: ``State(3, "active")`` (rclcpp_lifecycle::State)."""

    id: int
    label: str

    def __str__(self) -> str:
        return self.label


UNKNOWN = State(0, "unknown")
UNCONFIGURED = State(1, "unconfigured")
INACTIVE = State(2, "inactive")
ACTIVE = State(3, "active")
FINALIZED = State(4, "finalized")

STATES_BY_LABEL = {s.label: s for s in (UNKNOWN, UNCONFIGURED, INACTIVE, ACTIVE, FINALIZED)}
STATES_BY_ID = {s.id: s for s in (UNKNOWN, UNCONFIGURED, INACTIVE, ACTIVE, FINALIZED)}


def as_state(value) -> State:
    """Accept a State, a lifecycle id (3) or a label ("active"); refuse anything else clearly."""
    if isinstance(value, State):
        return value
    if isinstance(value, str) and value.lower() in STATES_BY_LABEL:
        return STATES_BY_LABEL[value.lower()]
    if isinstance(value, int) and not isinstance(value, bool) and value in STATES_BY_ID:
        return STATES_BY_ID[value]
    raise ValueError(f"unknown lifecycle state {value!r}: use one of "
                     f"{sorted(STATES_BY_LABEL)} or their ids 0-4 (e.g. 'active' or 3)")


# Standard interface names (hardware_interface/types/hardware_interface_type_values.hpp).
HW_IF_POSITION = "position"
HW_IF_VELOCITY = "velocity"
HW_IF_ACCELERATION = "acceleration"
HW_IF_EFFORT = "effort"
