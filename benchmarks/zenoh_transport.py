"""What the process boundary costs: the in-process bus vs robocourse over zenoh vs raw zenoh,
and the chapter 2 pendulum graph split across two processes at 1 kHz. Same run, same payloads.

    .venv/bin/python benchmarks/zenoh_transport.py [--repeats 5] [--n 1000] [--quick]

A zenoh router runs in this process on a free loopback port (rmw_zenoh's defaults: peers,
multicast scouting off). Rows:

- latency: ping-pong round trips (publish on /ping -> an echo republishes on /pong -> back),
  one message in flight, p50/p99 of the round trip in microseconds. Payload
  ``std_msgs/String`` as CDR: "small" (a 20-character stamp, 32 B) and "1 kB" (1024 B).
  * in-process bus: the echo node on the same Context and executor (no serialization);
  * robocourse/zenoh: the echo is ``python -m robocourse.bus.zenoh.peer echo`` in another
    process; each side puts CDR + the 33-byte attachment on rmw_zenoh's keys;
  * raw zenoh: a plain eclipse-zenoh echo process (this file, ``--role raw-echo``) and plain
    ``put``/subscriber callbacks on two keys carrying the same CDR bytes: the floor.
- throughput: N messages published back to back (RELIABLE + KEEP_ALL, so zenoh blocks
  instead of dropping), msgs/s until the N-th echo is back (a round trip per message,
  pipelined).
- pendulum: ``pendulum_motor`` (physics thread, sensor every 970 us) and
  ``pendulum_controller`` (PID, command every 960 us) with the seed's topics and QoS
  (BEST_EFFORT, KEEP_LAST 1), for ``--seconds`` each, in one process and then split across two
  processes; the setpoint moves (a 0.5 rad, 0.5 Hz sine) so the pendulum keeps moving. A message is *late* if its one-way latency (publish -> subscription callback,
  wall clock, same machine) exceeds the 1 ms control period, or if it never arrives. Messages
  are matched by value (every sensor state and PID command is a distinct float).

Every row is the median over ``--repeats`` interleaved repeats, with the min..max spread;
ratios are robocourse/zenoh over raw zenoh (the goal is p50 <= 1.5x) and over the in-process
bus. The machine is shared: only same-run ratios compare.

Example output of one run (``--repeats 5 --n 500 --flood 2000 --seconds 3``, 2026-11 branch
zenohperf, a shared 2-core box under other load; one run's figures, not a specification):

    small (29 B) robocourse/zenoh   p50 375.4 [315.3..458.4]   raw zenoh 198.0 [179.5..212.4]
      -> 1.90x raw zenoh (per-repeat 1.48..2.30; goal <= 1.5x: NOT met)
    1 kB (1021 B) robocourse/zenoh  p50 374.3 [260.9..398.2]   raw zenoh 185.7 [120.2..250.4]
      -> 2.02x raw zenoh (per-repeat 1.45..2.21; goal <= 1.5x: NOT met)
    pendulum, two processes: 0.55 % late [0.5..1.4] (goal < 1 %: met), sensor p99 684 us

Most of what remains over raw zenoh is the executor hand-off in the echo process (the raw
echo answers inside zenoh's callback thread; a robocourse subscription callback runs on the
spinning thread, as in rclpy) and the pure-Python CDR codec on each hop.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "lib"))

RAW_PING, RAW_PONG = "bench/raw/ping", "bench/raw/pong"
SIZES = {"small": 20, "1 kB": 1012}          # string characters -> CDR 32 B / 1024 B
PERIOD_NS = 1_000_000


def _config(endpoint):
    import zenoh

    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("connect/endpoints", f'["{endpoint}"]')
    conf.insert_json5("listen/endpoints", '["tcp/127.0.0.1:0"]')
    conf.insert_json5("scouting/multicast/enabled", "false")
    return conf


def raw_echo(endpoint):
    """The raw zenoh echo process: every sample on RAW_PING is put back on RAW_PONG."""
    import zenoh

    s = zenoh.open(_config(endpoint))
    pub = s.declare_publisher(RAW_PONG, congestion_control=zenoh.CongestionControl.BLOCK,
                              reliability=zenoh.Reliability.RELIABLE)
    s.declare_subscriber(RAW_PING, lambda sample: pub.put(sample.payload))
    print("READY", flush=True)
    sys.stdin.read()            # until the parent closes the pipe
    s.close()


# ------------------------------------------------------------------------------ ping-pong rows
def _payload(size):
    from robocourse.msgs.std_msgs import String

    return String(data="x" * SIZES[size])


class BusSide:
    """/ping publisher and /pong subscription on a Context (in-process or zenoh)."""

    def __init__(self, ctx, local_echo):
        from robocourse.bus import HistoryPolicy, QoSProfile, SingleThreadedExecutor
        from robocourse.msgs.std_msgs import String

        qos = QoSProfile(depth=7, history=HistoryPolicy.KEEP_ALL)
        self.node = ctx.create_node(f"bench_{os.getpid()}_{id(self)}")
        self.pub = self.node.create_publisher(String, "/ping", qos)
        self.got = 0
        self.node.create_subscription(String, "/pong", self._on_pong, qos)
        self.ex = SingleThreadedExecutor(context=ctx)
        self.ex.add_node(self.node)
        if local_echo:
            echo = ctx.create_node("echo")
            pub = echo.create_publisher(String, "/pong", qos)
            echo.create_subscription(String, "/ping", pub.publish, qos)
            self.ex.add_node(echo)
        self.t_recv = 0

    def _on_pong(self, _msg):
        self.t_recv = time.perf_counter_ns()
        self.got += 1

    def wait(self, count, timeout=10.0):
        end = time.monotonic() + timeout
        while self.got < count and time.monotonic() < end:
            self.ex.spin_once(timeout_sec=0.05)
        return self.got >= count

    def pingpong(self, msg, n):
        rtt = []
        for _ in range(n):
            want = self.got + 1
            t0 = time.perf_counter_ns()
            self.pub.publish(msg)
            if not self.wait(want):
                raise RuntimeError("echo did not answer within 10 s")
            rtt.append(self.t_recv - t0)
        return rtt

    def flood(self, msg, n):
        start_got = self.got
        t0 = time.perf_counter_ns()
        for _ in range(n):
            self.pub.publish(msg)
        ok = self.wait(start_got + n, timeout=60)
        dt = (self.t_recv - t0) / 1e9
        return (self.got - start_got) / dt if ok else float("nan")


class RawSide:
    def __init__(self, endpoint):
        import zenoh

        self.s = zenoh.open(_config(endpoint))
        self.pub = self.s.declare_publisher(RAW_PING,
                                            congestion_control=zenoh.CongestionControl.BLOCK,
                                            reliability=zenoh.Reliability.RELIABLE)
        self.cv = threading.Condition()
        self.got = 0
        self.t_recv = 0
        self.sub = self.s.declare_subscriber(RAW_PONG, self._on_pong)

    def _on_pong(self, _sample):
        with self.cv:
            self.t_recv = time.perf_counter_ns()
            self.got += 1
            self.cv.notify()

    def _wait(self, count, timeout):
        with self.cv:
            return self.cv.wait_for(lambda: self.got >= count, timeout)

    def pingpong(self, payload, n):
        rtt = []
        for _ in range(n):
            want = self.got + 1
            t0 = time.perf_counter_ns()
            self.pub.put(payload)
            if not self._wait(want, 10):
                raise RuntimeError("raw echo did not answer within 10 s")
            rtt.append(self.t_recv - t0)
        return rtt

    def flood(self, payload, n):
        start = self.got
        t0 = time.perf_counter_ns()
        for _ in range(n):
            self.pub.put(payload)
        ok = self._wait(start + n, 60)
        return (self.got - start) / ((self.t_recv - t0) / 1e9) if ok else float("nan")


# ------------------------------------------------------------------------------ pendulum split
def pendulum_role(role, endpoint, seconds, out):
    """One half (or, with role 'both', all) of the seed's graph; logs publish/receive times."""
    from robocourse.bus import Context, SingleThreadedExecutor
    from robocourse.pendulum import demo
    from robocourse.pendulum.msgs import JointCommand, JointState

    ctx = Context(transport="zenoh", connect=[endpoint]) if endpoint else Context()
    ex = SingleThreadedExecutor(context=ctx)
    log = {"sensor_pub": [], "sensor_recv": [], "command_pub": [], "command_recv": []}
    now = time.time_ns                      # wall clock: comparable across processes
    motor = demo.PendulumMotor(initial_position=0.1)
    controller = demo.PendulumController(verbose=False)
    if role in ("motor", "both"):
        mn = ctx.create_node("pendulum_motor")
        sensor_pub = mn.create_publisher(JointState, "pendulum_sensor", demo.QOS_REALTIME)

        def on_command(msg):
            log["command_recv"].append((now(), msg.position))
            motor.on_command_message(msg)
        mn.create_subscription(JointCommand, "pendulum_command", on_command, demo.QOS_REALTIME)

        def motor_publish():
            if motor.message_ready:
                m = motor.sensor_message
                log["sensor_pub"].append((now(), m.position, m.velocity))
                sensor_pub.publish(m)
        mn.create_timer(demo.MOTOR_PERIOD_NS * 1e-9, motor_publish)
        ex.add_node(mn)
    if role in ("controller", "both"):
        cn = ctx.create_node("pendulum_controller")
        command_pub = cn.create_publisher(JointCommand, "pendulum_command", demo.QOS_REALTIME)

        def on_sensor(msg):
            log["sensor_recv"].append((now(), msg.position, msg.velocity))
            controller.on_sensor_message(msg)
        cn.create_subscription(JointState, "pendulum_sensor", on_sensor, demo.QOS_REALTIME)

        t_start = time.monotonic()

        def controller_publish():
            # a moving setpoint (0.5 rad sine at 0.5 Hz around the demo's): the pendulum
            # keeps moving, so every sensor state and command is a distinct value to match
            controller.pid.command = math.pi / 2 + 0.5 * math.sin(math.pi * (time.monotonic() - t_start))
            if controller.message_ready:
                log["command_pub"].append((now(), controller.command_message.position))
                command_pub.publish(controller.command_message)
        cn.create_timer(demo.CONTROLLER_PERIOD_NS * 1e-9, controller_publish)
        ex.add_node(cn)
    if endpoint:
        others = {"motor": "MS", "controller": "MS"}[role]
        ctx.transport.wait_for(lambda t: len(t.remote_entities(others)) >= 1, 20)
        print("READY", flush=True)
        sys.stdin.readline()                # both halves start together
    if role in ("motor", "both"):
        motor.start()
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        ex.spin_once(timeout_sec=0.01)
    motor.set_done()
    ctx.try_shutdown()
    with open(out, "w") as f:
        json.dump(log, f)


def late_fraction(pubs, recvs):
    """(late fraction, p50 us, p99 us): pubs matched to receptions by value; a message that
    never arrives counts as late. Duplicate values (republished unchanged) count once."""
    first_pub = {}
    for t, *v in pubs:
        first_pub.setdefault(tuple(v), t)
    first_recv = {}
    for t, *v in recvs:
        first_recv.setdefault(tuple(v), t)
    lat = [first_recv[v] - t for v, t in first_pub.items() if v in first_recv]
    lost = len(first_pub) - len(lat)
    late = sum(1 for x in lat if x > PERIOD_NS) + lost
    a = np.asarray(lat, dtype=float) / 1e3
    return late / max(len(first_pub), 1), float(np.percentile(a, 50)), float(np.percentile(a, 99))


def pendulum_run(endpoint, seconds, split):
    tmp = tempfile.mkdtemp(prefix="zbench_")
    logs = {}
    if not split:
        out = os.path.join(tmp, "both.json")
        pendulum_role("both", None, seconds, out)
        with open(out) as f:
            logs = json.load(f)
    else:
        procs = {}
        for role in ("motor", "controller"):
            procs[role] = subprocess.Popen(
                [sys.executable, __file__, "--role", role, "--connect", endpoint,
                 "--seconds", str(seconds), "--out", os.path.join(tmp, f"{role}.json")],
                stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        for p in procs.values():
            if "READY" not in p.stdout.readline():
                raise RuntimeError("pendulum half did not start")
        for p in procs.values():
            p.stdin.write("go\n")
            p.stdin.flush()
        for role, p in procs.items():
            p.wait(timeout=seconds + 60)
            with open(os.path.join(tmp, f"{role}.json")) as f:
                for k, v in json.load(f).items():
                    logs.setdefault(k, []).extend(v)
    s = late_fraction(logs["sensor_pub"], logs["sensor_recv"])
    c = late_fraction(logs["command_pub"], logs["command_recv"])
    n_s, n_c = len(logs["sensor_pub"]), len(logs["command_pub"])
    late = (s[0] * n_s + c[0] * n_c) / max(n_s + n_c, 1)
    return {"late": late, "sensor_p50": s[1], "sensor_p99": s[2], "command_p50": c[1],
            "command_p99": c[2], "messages": n_s + n_c}


# ------------------------------------------------------------------------------ main
def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _spawn(args):
    p = subprocess.Popen([sys.executable, *args], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                         text=True)
    if "READY" not in p.stdout.readline():
        raise RuntimeError(f"{args} did not start")
    return p


def med(xs):
    xs = [x for x in xs if x == x]
    return (statistics.median(xs), min(xs), max(xs)) if xs else (float("nan"),) * 3


def fmt(t, unit=""):
    m, lo, hi = t
    if m >= 1000:
        return f"{m:,.0f}{unit} [{lo:,.0f}..{hi:,.0f}]"
    return f"{m:.1f}{unit} [{lo:.1f}..{hi:.1f}]"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--role", choices=["raw-echo", "motor", "controller"])
    ap.add_argument("--connect")
    ap.add_argument("--out")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--n", type=int, default=1000, help="round trips per row and repeat")
    ap.add_argument("--flood", type=int, default=5000, help="messages per throughput run")
    ap.add_argument("--seconds", type=float, default=5.0, help="pendulum run length")
    ap.add_argument("--quick", action="store_true", help="3 repeats, fewer messages")
    a = ap.parse_args()
    if a.role == "raw-echo":
        return raw_echo(a.connect)
    if a.role in ("motor", "controller"):
        return pendulum_role(a.role, a.connect, a.seconds, a.out)
    if a.quick:
        a.repeats, a.n, a.flood, a.seconds = 3, 300, 1000, 2.0

    from robocourse.bus import Context
    from robocourse.bus.zenoh import wire
    from robocourse.bus.zenoh.transport import router

    ep = f"tcp/127.0.0.1:{_free_port()}"
    r = router([ep])
    procs = [_spawn(["-m", "robocourse.bus.zenoh.peer", "echo", "--connect", ep, "--keep-all"]),
             _spawn([__file__, "--role", "raw-echo", "--connect", ep])]
    inproc = BusSide(Context(), local_echo=True)
    zctx = Context(transport="zenoh", connect=[ep])
    rc = BusSide(zctx, local_echo=False)
    zctx.transport.wait_for(lambda t: len([e for e in t.remote_entities("MS")
                                           if e.topic == "/ping"]) == 1, 20)
    raw = RawSide(ep)
    time.sleep(0.5)
    rows = {}                       # (size, path) -> {"p50": [], "p99": [], "tput": []}
    paths = ("in-process bus", "robocourse/zenoh", "raw zenoh")
    print(f"# {a.repeats} repeats x {a.n} round trips, {a.flood}-message floods; router {ep}",
          flush=True)
    for rep in range(a.repeats):
        for size in SIZES:
            msg = _payload(size)
            cdr = wire.to_cdr(msg)
            order = list(paths) if rep % 2 == 0 else list(reversed(paths))
            for path in order:
                side = {"in-process bus": inproc, "robocourse/zenoh": rc, "raw zenoh": raw}[path]
                item = cdr if path == "raw zenoh" else msg
                side.pingpong(item, 50)                      # warm-up
                rtt = np.asarray(side.pingpong(item, a.n), dtype=float) / 1e3
                tput = side.flood(item, a.flood)
                d = rows.setdefault((size, path), {"p50": [], "p99": [], "tput": []})
                d["p50"].append(float(np.percentile(rtt, 50)))
                d["p99"].append(float(np.percentile(rtt, 99)))
                d["tput"].append(tput)
        print(f"  repeat {rep + 1}/{a.repeats} done", flush=True)
    pend = {"one process": [], "two processes": []}
    for rep in range(a.repeats):
        for split in ((False, True) if rep % 2 == 0 else (True, False)):
            key = "two processes" if split else "one process"
            pend[key].append(pendulum_run(ep, a.seconds, split))
        print(f"  pendulum repeat {rep + 1}/{a.repeats} done", flush=True)
    for p in procs:
        p.stdin.close()
        p.wait(timeout=10)
    zctx.try_shutdown()
    raw.s.close()
    r.close()

    print("\nround trip (publish -> echo in the other process -> back), microseconds; "
          "median [min..max] over repeats")
    print(f"{'payload':8} {'path':18} {'p50 us':>24} {'p99 us':>26} {'msgs/s':>26}")
    for size in SIZES:
        cdr_len = len(wire.to_cdr(_payload(size)))
        for path in paths:
            d = rows[(size, path)]
            print(f"{size + f' ({cdr_len} B)':8} {path:18} {fmt(med(d['p50'])):>24} "
                  f"{fmt(med(d['p99'])):>26} {fmt(med(d['tput'])):>26}")
        rc50, raw50 = med(rows[(size, "robocourse/zenoh")]["p50"])[0], \
            med(rows[(size, "raw zenoh")]["p50"])[0]
        in50 = med(rows[(size, "in-process bus")]["p50"])[0]
        rct, rawt = med(rows[(size, "robocourse/zenoh")]["tput"])[0], \
            med(rows[(size, "raw zenoh")]["tput"])[0]
        ratios = [rows[(size, "robocourse/zenoh")]["p50"][i] / rows[(size, "raw zenoh")]["p50"][i]
                  for i in range(a.repeats)]
        print(f"  {size}: robocourse/zenoh p50 = {rc50 / raw50:.2f}x raw zenoh (per-repeat "
              f"{min(ratios):.2f}..{max(ratios):.2f}; goal <= 1.5x: "
              f"{'met' if rc50 / raw50 <= 1.5 else 'NOT met'}), {rc50 / in50:.1f}x the "
              f"in-process bus; throughput {rct / rawt:.2f}x raw zenoh")
    print(f"\npendulum graph at 1 kHz for {a.seconds:g} s: late = one-way latency > 1 ms or lost "
          f"(sensor + command messages); median [min..max] over repeats")
    print(f"{'graph':14} {'late %':>22} {'sensor p50 us':>24} {'sensor p99 us':>26} "
          f"{'command p99 us':>26} {'messages':>9}")
    for key, runs in pend.items():
        print(f"{key:14} {fmt(med([100 * x['late'] for x in runs])):>22} "
              f"{fmt(med([x['sensor_p50'] for x in runs])):>24} "
              f"{fmt(med([x['sensor_p99'] for x in runs])):>26} "
              f"{fmt(med([x['command_p99'] for x in runs])):>26} "
              f"{int(statistics.median([x['messages'] for x in runs])):>9}")
    late2 = med([100 * x["late"] for x in pend["two processes"]])[0]
    print(f"  two processes: {late2:.2f} % late (goal < 1 %: {'met' if late2 < 1 else 'NOT met'})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
