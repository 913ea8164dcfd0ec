"""``robocourse control ...``: the ``ros2 control`` verbs and the spawner, on a robot brought up in-process.

ROS 2's verbs talk to a controller manager that already runs; robocourse's bus lives in one
process, so each command first brings the robot up (``--robot``/``--urdf``, ``--plugin``,
``--controllers-file``, ``--spawn``/``--spawn-inactive`` as a launch file would), runs a few cycles,
then performs the verb through the manager's services and prints what ``ros2 control`` prints.
"""

from __future__ import annotations

import argparse

VERBS = ("list_controllers", "list_hardware_interfaces", "list_hardware_components", "switch_controllers",
         "load_controller", "set_hardware_component_state", "spawner", "view")


def _common(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("bring-up (what the launch file would start)")
    g.add_argument("--robot", default="rrbot", choices=("rrbot", "ur5e"), help="shipped robot (default rrbot)")
    g.add_argument("--urdf", help="your own URDF file instead of a shipped robot")
    g.add_argument("--plugin", help="hardware plugin for the shipped robot (default mock_components/GenericSystem; "
                                    "robocourse/MujocoSystem simulates it)")
    g.add_argument("--controllers-file", dest="bringup_params", help="controller_manager parameter file "
                                                               "(default: the robot's shipped one)")
    g.add_argument("--spawn", nargs="*", default=[], metavar="NAME", help="controllers to load and activate first")
    g.add_argument("--spawn-inactive", nargs="*", default=[], metavar="NAME",
                   help="controllers to load and configure first")
    g.add_argument("--cycles", type=int, default=10, help="manager cycles to run before the verb (default 10)")


def register(sub) -> None:
    p = sub.add_parser("control", help="ros2 control's verbs and the spawner (ros2_control in Python)")
    s = p.add_subparsers(dest="control_command", metavar="VERB")
    v = s.add_parser("list_controllers", help="output the list of loaded controllers, their type and status")
    v.add_argument("-v", "--verbose", action="store_true")
    v = s.add_parser("list_hardware_interfaces", help="output the list of available command and state interfaces")
    v.add_argument("-v", "--verbose", action="store_true")
    v = s.add_parser("list_hardware_components", help="output the list of hardware components")
    v.add_argument("-v", "--verbose", action="store_true")
    v = s.add_parser("switch_controllers", help="switch controllers in a controller manager")
    v.add_argument("--activate", nargs="*", default=[])
    v.add_argument("--deactivate", nargs="*", default=[])
    v.add_argument("--strict", action="store_true")
    v.add_argument("--activate-asap", action="store_true")
    v.add_argument("--switch-timeout", type=float, default=5.0)
    v = s.add_parser("load_controller", help="load a controller in a controller manager")
    v.add_argument("controller_name")
    v.add_argument("--set-state", choices=("inactive", "active"))
    v = s.add_parser("set_hardware_component_state", help="adjust the state of the hardware component")
    v.add_argument("hardware_component_name")
    v.add_argument("state", choices=("unconfigured", "inactive", "active"))
    v = s.add_parser("spawner", help="load, configure and activate controllers (controller_manager spawner)")
    v.add_argument("controller_names", nargs="+")
    v.add_argument("--inactive", action="store_true", help="load and configure only")
    v.add_argument("-p", "--param-file", help="controller parameter file")
    v.add_argument("-t", "--controller-type")
    v.add_argument("--activate-as-group", action="store_true")
    v = s.add_parser("view", help="write an SVG picture of the system (components, interfaces, controllers, claims)")
    v.add_argument("output", nargs="?", default=None,
                   help="SVG file to write (default: <robot>_system.svg in the current folder)")
    for verb in s.choices.values():
        _common(verb)
        verb.set_defaults(func=run)
    p.set_defaults(func=lambda args: p.print_help() or 2)


def _check_args(args) -> str | None:
    """The first bad argument, as 'value: rule; fix', before anything is brought up (None: all good)."""
    from pathlib import Path

    from robocourse.control.bringup import default_param_file
    from robocourse.control.parameters import load_parameter_file, params_for

    if args.urdf and not Path(args.urdf).is_file():
        return f"--urdf {args.urdf!r}: no such file; give the path of your URDF, e.g. --urdf my_robot.urdf"
    params = args.bringup_params or (None if args.urdf else default_param_file(args.robot))
    if params is not None and not Path(params).is_file():
        return f"--controllers-file {str(params)!r}: no such file; give a controller_manager parameter file"
    if args.control_command == "view":
        if args.output is None:
            args.output = f"{Path(args.urdf).stem if args.urdf else args.robot}_system.svg"
        out = Path(args.output)
        if out.suffix.lower() != ".svg":
            return f"output {args.output!r}: view writes an SVG picture; name the file .svg, e.g. {out.stem}.svg"
        if out.is_dir() or not out.resolve().parent.is_dir():
            return (f"output {args.output!r}: {'is a folder' if out.is_dir() else 'its folder does not exist'}; "
                    f"give a file path in an existing folder, e.g. system.svg")
    # the bring-up's controllers (what a launch file spawns); the verbs themselves (load_controller,
    # spawner) answer an unknown name as ros2 control does: an error line and exit code 1
    wanted = [("--spawn", n) for n in args.spawn] + [("--spawn-inactive", n) for n in args.spawn_inactive]
    if wanted and params is not None:
        declared = sorted(k[:-len(".type")] for k in params_for(load_parameter_file(params), "controller_manager")
                          if k.endswith(".type"))
        for flag, name in wanted:
            if name not in declared:
                return (f"{flag} {name!r}: no such controller in {params} (a controller needs a '<name>.type' "
                        f"under controller_manager's ros__parameters); declared there: "
                        f"{', '.join(declared) or 'none'}; spawn one of them, or add it to the file")
    return None


def run(args) -> int:
    import sys
    from pathlib import Path

    from robocourse.control import introspection as ic
    from robocourse.control.bringup import bringup
    from robocourse.control.log import LogSink

    problem = _check_args(args)
    if problem:
        print(f"robocourse control {args.control_command}: error: {problem}", file=sys.stderr)
        return 2
    urdf = Path(args.urdf).read_text() if args.urdf else None
    cm = bringup(args.robot, urdf=urdf, plugin=args.plugin, param_file=args.bringup_params, spawn=args.spawn,
                 inactive=args.spawn_inactive, log=LogSink(log_to_stderr=False))
    cm.step(max(0, args.cycles))
    verb = args.control_command
    ok = True
    if verb == "list_controllers":
        ic.list_controllers(cm, verbose=args.verbose)
    elif verb == "list_hardware_interfaces":
        ic.list_hardware_interfaces(cm, verbose=args.verbose)
    elif verb == "list_hardware_components":
        ic.list_hardware_components(cm, verbose=args.verbose)
    elif verb == "switch_controllers":
        ok = ic.switch_controllers(cm, args.activate, args.deactivate, args.strict, args.activate_asap,
                                   args.switch_timeout)
    elif verb == "load_controller":
        ok = ic.load_controller(cm, args.controller_name, args.set_state)
    elif verb == "set_hardware_component_state":
        ok = ic.set_hardware_component_state(cm, args.hardware_component_name, args.state)
    elif verb == "spawner":
        ok = ic.spawner(cm, args.controller_names, inactive=args.inactive, param_file=args.param_file,
                        controller_type=args.controller_type, activate_as_group=args.activate_as_group)
    elif verb == "view":
        from robocourse.control.picture import system_picture

        system_picture(cm).save(args.output)
        print(f"wrote {args.output}")
    if not ok:
        for rec in cm.log.records:
            if rec.severity >= 40:
                print(str(rec), file=sys.stderr)
    return 0 if ok else 1
