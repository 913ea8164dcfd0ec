"""The UR-style box's dashboard server (TCP 29999): one text line in, one text line out.

Counterpart: the e-Series PolyScope dashboard server, as ur_rtde's ``DashboardClient`` and
ur_robot_driver's dashboard client use it. On connect the server greets with
``Connected: Universal Robots Dashboard Server``; every command ends with ``\\n`` and gets one
line back, with UR's reply strings (those ur_rtde compares exactly: ``Starting program``,
``Stopped``, ``Pausing program``, ``Protective stop releasing``, ``Loading program: ...``).

Supported: ``PolyscopeVersion``, ``version``, ``get serial number``, ``get robot model``,
``is in remote control`` (always ``true``: the box has no local mode), ``robotmode``,
``safetymode``, ``safetystatus``, ``programState``, ``running``, ``get loaded program``,
``isProgramSaved``, ``power on``, ``power off``, ``brake release``, ``play``, ``stop``,
``pause``, ``load <file>`` (there are no program files: ``File not found: <file>``),
``unlock protective stop``, ``close safety popup``, ``restart safety``, ``popup <text>``,
``close popup``, ``addToLog <text>``, ``quit``, ``shutdown`` (the box process exits).
Anything else: ``could not understand: '<line>'``, as UR answers. Ours, not UR's:
``robocourse stats`` answers one JSON line of the box's counters, ``robocourse trace`` one JSON
line of its last seconds of trajectory (tests, benchmarks, the graders).

``play`` resumes a paused program (there is no loaded .urp to start); ``stop`` answers
``Stopped`` also when nothing runs (ur_rtde sends it after stopping its own script).
"""

from __future__ import annotations

from . import ur_controller as uc

WELCOME = "Connected: Universal Robots Dashboard Server"


def polyscope_version(version) -> str:
    return "URSoftware {}.{}.{}.{} (robocourse UR-style box)".format(*version)


def answer(ctrl: uc.URController, line: str) -> tuple[str, str | None]:
    """(reply line, action): action "quit" closes this connection, "shutdown" ends the box."""
    cmd = line.strip()
    low = cmd.lower()
    c = ctrl
    if low == "polyscopeversion":
        return polyscope_version(uc.CONTROLLER_VERSION), None
    if low == "version":
        return "Version: {}.{}.{}.{}".format(*uc.CONTROLLER_VERSION), None
    if low == "get serial number":
        return uc.SERIAL_NUMBER, None
    if low == "get robot model":
        return uc.ROBOT_MODEL, None
    if low == "is in remote control":
        return "true", None
    if low == "robotmode":
        return f"Robotmode: {uc.ROBOT_MODE_NAMES[c.robot_mode]}", None
    if low == "safetymode":
        return f"Safetymode: {uc.SAFETY_MODE_NAMES[c.safety_mode]}", None
    if low == "safetystatus":
        return f"Safetystatus: {uc.SAFETY_MODE_NAMES[c.safety_mode]}", None
    if low == "programstate":
        return f"{uc.RUNTIME_NAMES[c.runtime_state]} {c.last_program or '<unnamed>'}", None
    if low == "running":
        return f"Program running: {'true' if c.runtime_state == uc.RUNTIME_PLAYING else 'false'}", None
    if low == "get loaded program":
        return (f"Loaded program: {c.last_program}" if c.last_program else "No program loaded"), None
    if low == "isprogramsaved":
        return f"True {c.last_program or '<unnamed>'}", None
    if low == "power on":
        c.power(True)
        return "Powering on", None
    if low == "power off":
        c.power(False)
        return "Powering off", None
    if low == "brake release":
        c.brake_release()
        return "Brake releasing", None
    if low == "play":
        if c.runtime_state == uc.RUNTIME_PAUSED and c.robot_mode == uc.ROBOT_MODE_RUNNING:
            c.runtime_state = uc.RUNTIME_PLAYING
            return "Starting program", None
        return "Failed to execute: play", None
    if low == "stop":
        c.stop_program("stop from the dashboard")
        return "Stopped", None
    if low == "pause":
        if c.runtime_state == uc.RUNTIME_PLAYING:
            c.runtime_state = uc.RUNTIME_PAUSED
            c.motion.stop(uc.STOP_DECELERATION)
            return "Pausing program", None
        return "Failed to execute: pause", None
    if low.startswith("load "):
        return f"File not found: {cmd[5:].strip()}", None
    if low == "unlock protective stop":
        return c.unlock_protective_stop(), None
    if low == "close safety popup":
        return "closing safety popup", None
    if low == "restart safety":
        if c.safety_mode != uc.SAFETY_NORMAL:
            c.safety_mode = uc.SAFETY_NORMAL
            c.power(False)
        return "Restarting safety", None
    if low.startswith("popup "):
        return "showing popup", None
    if low == "close popup":
        return "closing popup", None
    if low.startswith("addtolog"):
        return ("Added log message" if cmd[8:].strip() else "No log message to add"), None
    if low == "quit":
        return "Disconnected", "quit"
    if low == "shutdown":
        return "Shutting down", "shutdown"
    if low == "robocourse stats":
        return "", "stats"
    if low == "robocourse trace":
        return "", "trace"
    return f"could not understand: '{cmd}'", None
