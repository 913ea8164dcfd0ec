"""robocourse.control.manager: ros2_control's resource manager, controller interface and controller manager.

- ``loaned``: loaned state/command interfaces (views into the resource manager's arrays);
- ``resource_manager``: components, interface values, claims, hardware lifecycle, read/write;
- ``controller_interface``: ControllerInterface / ChainableControllerInterface;
- ``controller_manager``: load / configure / switch / chain / update, faults and fallbacks;
- ``loop``: the wall-clock loop with per-stage timing; ``services``: the manager's bus services.
"""
