"""``robocourse mycar demo`` (the scripted mission) and ``robocourse mycar teleop`` (keys)."""

from __future__ import annotations


def register(sub):
    p = sub.add_parser("mycar", help="the ROS2 MyCar tutorial's car: demo mission, teleop")
    s = p.add_subparsers(dest="mycar_command", metavar="ACTION")
    d = s.add_parser("demo", help="drive, LED service, two navigation goals (one cancelled), record to MCAP")
    d.add_argument("--record", metavar="FILE.mcap", help="record the mission (opens in Foxglove)")
    d.add_argument("--config", help="ROS 2 parameter file (default: the package's mycar.yaml)")
    d.set_defaults(func=run_demo)
    t = s.add_parser("teleop", help="drive the car (simulated driver, wall clock) with keys until Ctrl-C")
    t.set_defaults(func=run_teleop)
    p.set_defaults(func=lambda args: p.print_help() or 2)


def _check_record(path: str | None) -> str | None:
    """Why ``--record path`` cannot be written (None: it can), before the mission runs."""
    import os

    if path is None:
        return None
    if os.path.isdir(path):
        return (f"--record {path!r}: is a folder; the recording is one MCAP file, e.g. "
                f"--record {os.path.join(path, 'mission.mcap')}")
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        return f"--record {path!r}: the folder {folder} does not exist; create it or record elsewhere, e.g. --record mission.mcap"
    if not os.access(folder, os.W_OK):
        return f"--record {path!r}: the folder {folder} is not writable by you; record elsewhere, e.g. --record mission.mcap"
    return None


def run_demo(args) -> int:
    import sys

    from robocourse.mycar.mission import run_mission

    problem = _check_record(args.record)
    if problem is None and args.config is not None and not __import__("os").path.isfile(args.config):
        problem = f"--config {args.config!r}: no such file; give a ROS 2 parameter file (YAML), e.g. --config mycar.yaml"
    if problem:
        print(f"robocourse mycar demo: error: {problem}", file=sys.stderr)
        return 2
    rep = run_mission(args.record, config=args.config)
    print("\nmission summary:")
    print(f"  LED 1 on: {rep.led_ok}; LED 7 refused: {not rep.led_invalid_ok}")
    for target, status, message in rep.goals:
        print(f"  goal {target}: {status} ({message})")
    print(f"  /odom messages: {rep.odom_published}; watchdog stops: {rep.watchdog_trips}")
    if rep.final_truth:
        dx, dy = rep.final_odom[0] - rep.final_truth[0], rep.final_odom[1] - rep.final_truth[1]
        print(f"  odometry drift from ground truth: {(dx * dx + dy * dy) ** 0.5 * 100:.1f} cm")
    return 0


def run_teleop(args) -> int:
    import sys
    import threading

    from robocourse.bus import Context
    from robocourse.mycar.launch import launch
    from robocourse.mycar.teleop import TeleopNode, run_terminal

    car = launch(Context(), use_sim=False)
    teleop = TeleopNode(context=car.context)
    car.executor.add_node(teleop)
    spinner = threading.Thread(target=car.executor.spin, daemon=True)
    spinner.start()
    sent = run_terminal(teleop, sys.stdin)
    x, y, yaw = car.driver.pose
    print(f"sent {sent} commands; odometry pose x={x:.3f} y={y:.3f} yaw={yaw:.3f}")
    car.context.try_shutdown()
    spinner.join(timeout=2)
    return 0
