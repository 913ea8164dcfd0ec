"""Argument checks shared by the bus's public entry points: value, rule and fix in one message.

rclpy mostly asserts types deep inside (``spin_once('1')`` fails in C with a bare TypeError);
here a bad argument is refused before any work is done, naming the call, the value, the rule
and an example of the fix.
"""

from __future__ import annotations

import math
from enum import IntEnum


def seconds(value, what: str, *, allow_none: bool = False, name: str = "timeout_sec") -> None:
    """A duration in seconds: a finite real >= 0 (or None when allowed)."""
    if value is None and allow_none:
        return
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or value < 0:
        rule = "a finite number of seconds >= 0" + (" or None (no limit)" if allow_none else "")
        raise (TypeError if not isinstance(value, (int, float)) else ValueError)(
            f"{what}: {name}={value!r} must be {rule}; e.g. {what.split('(')[0]}({name}=1.0)")


def integer(value, what: str, name: str, minimum: int = 0) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise (TypeError if not isinstance(value, int) else ValueError)(
            f"{what}: {name}={value!r} must be an int >= {minimum}; e.g. {name}={max(minimum, 1)}")


def policy(value, enum: type[IntEnum], what: str, name: str) -> IntEnum:
    """An enum member or its int value (rclpy accepts both); strings get the member's name."""
    if isinstance(value, enum):
        return value
    if isinstance(value, int) and not isinstance(value, bool):
        try:
            return enum(value)
        except ValueError:
            pass
    members = ", ".join(f"{enum.__name__}.{m.name}" for m in enum if m.name != "UNKNOWN")
    hint = ""
    if isinstance(value, str) and value.upper() in enum.__members__:
        hint = f" (write {enum.__name__}.{value.upper()}, not the string {value!r})"
    raise TypeError(f"{what}: {name}={value!r} is not a {enum.__name__}{hint}; use one of "
                    f"{members}")


def topic_name(value, what: str, name: str = "topic") -> None:
    if not isinstance(value, str) or not value:
        raise TypeError(f"{what}: {name}={value!r} must be a non-empty str, e.g. 'chatter' or "
                        f"'/robot/cmd_vel'")


def callable_(value, what: str, name: str = "callback") -> None:
    if not callable(value):
        raise TypeError(f"{what}: {name}={value!r} must be callable (a function or a bound "
                        f"method taking the message), e.g. lambda msg: print(msg)")
