"""What a box process loads and what closing a UR driver costs (issue 25: chapter 5 starts about
twenty boxes in test mode, so their start-up and teardown are most of its fixed cost).

No timing here (that is benchmarks/notebook_times.py's job): the box imports only what it runs,
``robocourse.control`` still gives every name it exports, and URStyleSystem disconnects each
ur_rtde client once (ur_rtde's ``disconnect()`` and its destructor both end with a 500 ms sleep).
"""

from __future__ import annotations

import subprocess
import sys

import pytest

import robocourse.control as control
from robocourse.drivers.ur_system import URStyleSystem

HEAVY = ("robocourse.control.manager.controller_manager", "robocourse.bus", "robocourse.msgs")


@pytest.mark.parametrize("module", ["robocourse.drivers.franka_box", "robocourse.drivers.ur_box"])
def test_a_box_process_loads_neither_the_manager_nor_the_bus(module):
    code = (f"import sys, {module}; "
            f"print(','.join(m for m in {HEAVY!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    assert out.stdout.strip() == "", f"{module} pulled in {out.stdout.strip()}: the box process does not need them"


def test_control_still_exports_every_name_and_its_submodules():
    for name in control.__all__:
        assert getattr(control, name) is not None, name
    assert control.ControllerManager.__module__ == "robocourse.control.manager.controller_manager"
    assert control.introspection.__name__ == "robocourse.control.introspection"
    from robocourse.control import ACTIVE, STRICT, return_type  # noqa: F401  (the from-import path)
    with pytest.raises(AttributeError, match="no attribute 'no_such_name'"):
        control.no_such_name  # noqa: B018


class _Client:
    """Stands in for a ur_rtde interface: counts disconnect() calls and its own destruction."""

    def __init__(self, log):
        self.log = log

    def disconnect(self):
        self.log.append("disconnect")

    def __del__(self):
        self.log.append("destroyed")    # ur_rtde's destructor disconnects here (and sleeps 500 ms)


def test_ur_clients_held_by_the_component_alone_are_closed_by_their_destructor_only():
    log = []
    hw = URStyleSystem()
    hw.rtde_c, hw.rtde_r = _Client(log), _Client(log)
    hw._disconnect()
    assert hw.rtde_c is None and hw.rtde_r is None
    assert log == ["destroyed", "destroyed"]        # one disconnect each, not two


def test_a_ur_client_someone_else_holds_is_disconnected_explicitly():
    log = []
    hw = URStyleSystem()
    kept = _Client(log)
    hw.rtde_c, hw.rtde_r = kept, _Client(log)
    hw._disconnect()
    assert log == ["disconnect", "destroyed"]       # the shared one now, the other by its destructor
    del kept
    assert log == ["disconnect", "destroyed", "destroyed"]
