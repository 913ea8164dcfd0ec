"""robocourse.bus latency, throughput and CPU, side by side with baselines in the same run.

    python benchmarks/bus_latency.py [--quick] [--baseline-lib /path/to/old/lib]

``--baseline-lib`` runs the same rows against another robocourse tree (e.g. ``git archive main``
unpacked in /tmp) in a subprocess, interleaved repeat by repeat with this tree's, and prints
both with ratios: an old-vs-new table from one run on one (noisy) machine.

Rows:
- bus, same executor: a timer callback publishes a small message (std_msgs/Int64 carrying
  perf_counter_ns), a subscription on the same SingleThreadedExecutor receives it; latency is
  publish -> start of the subscription callback. msgs/s is the whole loop (timer + publish +
  delivery + callback) run flat out.
- bus, cross-thread: a plain thread publishes, the executor spins in the main thread.
- queue.Queue: a thread puts the stamp, another thread get()s it (the classic hand-off).
- zenoh: eclipse-zenoh same-session put -> subscriber callback (benchmark-only dependency:
  pip install -r benchmarks/requirements.txt).
- bus, same executor, larger messages: a timer publishes one reused message (the rclpy
  pattern ``msg.position[0] = x; pub.publish(msg)``): JointState with 7 joints (300 B as CDR),
  JointState with 25 joints (1 kB) and a Float64MultiArray of 12800 doubles (100 kB); latency
  is publish() -> start of the callback. Value semantics copy every message once per
  subscription, so these rows show how that cost grows with size.
Then the per-message cost of the copy against rclpy's way (CDR serialize on publish +
deserialize per subscription, measured with mcap_ros2's CDR codec, the anchor to beat), and
the CPU use of a 1 kHz, 5-node graph on the wall clock (process CPU time / wall time).
Every row reports medians over repeats; ratios are relative to the bus same-executor row.
"CPU us/msg" is process CPU time per message of the flat-out loop: on a shared machine it is
steadier than msgs/s (wall clock), which other processes halve or double from run to run.
"""

from __future__ import annotations

import argparse
import json
import os
import queue
import statistics
import struct
import sys
import threading
import time

import numpy as np


def _lib_path(argv):
    if "--lib" in argv:
        return argv[argv.index("--lib") + 1]
    return os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "lib")


LIB = os.path.abspath(_lib_path(sys.argv))
sys.path.insert(0, LIB)

from robocourse.bus import (  # noqa: E402
    Context,
    HistoryPolicy,
    QoSProfile,
    SingleThreadedExecutor,
)
from robocourse.msgs.sensor_msgs import JointState  # noqa: E402
from robocourse.msgs.std_msgs import Float64MultiArray, Int64  # noqa: E402

now = time.perf_counter_ns
KEEP_ALL = QoSProfile(history=HistoryPolicy.KEEP_ALL)


def pct(lat_ns):
    a = np.asarray(lat_ns, dtype=np.float64) / 1000.0
    return float(np.percentile(a, 50)), float(np.percentile(a, 99))


# ------------------------------------------------------------------------------- bus rows


def same_executor_run(n, msg_type, tick, sent_ns):
    """A timer (period 0) calls ``tick(pub)``; a subscription on the same executor records
    ``now() - sent_ns(msg)`` for the first n messages. Returns p50 us, p99 us, msgs/s (wall)
    and CPU us per message of the whole loop (timer + publish + delivery + callback)."""
    from robocourse.bus import Future

    ctx = Context()
    ctx.log_to_stderr = False
    a, b = ctx.create_node("talker"), ctx.create_node("listener")
    pub = a.create_publisher(msg_type, "lat", 10)
    lat = np.empty(n, dtype=np.int64)
    state = {"i": 0}
    fut = Future()

    def cb(msg):
        t = now()
        i = state["i"]
        if i < n:
            lat[i] = t - sent_ns(msg)
            state["i"] = i + 1
            if i + 1 == n:
                fut.set_result(True)

    timer = a.create_timer(0.0, lambda: tick(pub))
    b.create_subscription(msg_type, "lat", cb, 10)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(a)
    ex.add_node(b)
    t0, c0 = now(), time.process_time()
    ex.spin_until_future_complete(fut)
    elapsed, cpu = (now() - t0) / 1e9, time.process_time() - c0
    timer.cancel()
    p50, p99 = pct(lat)
    return p50, p99, n / elapsed, cpu / n * 1e6


def bus_same_executor(n):
    """A new Int64 carrying perf_counter_ns per publish (construction included)."""
    return same_executor_run(n, Int64, lambda pub: pub.publish(Int64(data=now())),
                             lambda msg: msg.data)


def joint_state(n_joints):
    return JointState(name=[f"joint_{i}" for i in range(n_joints)], position=[0.1] * n_joints,
                      velocity=[0.0] * n_joints, effort=[0.0] * n_joints)


def big_array(n_doubles=12_800):
    return Float64MultiArray(data=[0.5] * n_doubles)


SIZED = {
    "JointState 7 joints (300 B CDR)": (JointState, lambda: joint_state(7), "position"),
    "JointState 25 joints (1 kB CDR)": (JointState, lambda: joint_state(25), "position"),
    "Float64MultiArray 12800 (100 kB CDR)": (Float64MultiArray, big_array, "data"),
}


def bus_same_executor_sized(n, msg_type, make, field):
    """Latency publish() -> callback of one reused message changed before each publish."""
    msg = make()
    arr = getattr(msg, field)
    stamps = np.empty(n + 1, dtype=np.int64)
    k = [0]

    def tick(pub):
        i = min(k[0], n)
        arr[0] = float(i)
        k[0] += 1
        stamps[i] = now()
        pub.publish(msg)

    return same_executor_run(n, msg_type, tick, lambda m: stamps[int(getattr(m, field)[0])])


def copy_costs(n):
    """us per message: the generated copy vs CDR serialize + deserialize (rclpy's way)."""
    import timeit

    from mcap_ros2._dynamic import generate_dynamic, serialize_dynamic

    from robocourse.msgs import definition_name, full_definition

    out = {}
    cases = {"Int64": (Int64, lambda: Int64(data=5))}
    cases.update({k: (t, make) for k, (t, make, _) in SIZED.items()})
    for name, (t, make) in cases.items():
        msg = make()
        schema = definition_name(t._type)
        enc = serialize_dynamic(schema, full_definition(t))[schema]
        dec = generate_dynamic(schema, full_definition(t))[schema]
        reps = max(20, n // (1 if name == "Int64" else 20 if "100 kB" not in name else 2000))
        row = {"cdr_bytes": len(enc(msg))}
        row["cdr_us"] = min(timeit.repeat(lambda d=dec, e=enc, m=msg: d(e(m)), number=reps,
                                          repeat=3)) / reps * 1e6
        if hasattr(msg, "_copy"):
            row["copy_us"] = min(timeit.repeat(msg._copy, number=reps, repeat=3)) / reps * 1e6
        out[name] = row
    return out


def bus_burst_throughput(n):
    """Delivery + callback rate for a KEEP_ALL burst published before spinning."""
    ctx = Context(use_sim_time=True)
    a, b = ctx.create_node("a"), ctx.create_node("b")
    pub = a.create_publisher(Int64, "t", KEEP_ALL)
    count = [0]

    def cb(m):
        count[0] += 1

    b.create_subscription(Int64, "t", cb, KEEP_ALL)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(b)
    msgs = [Int64(data=i) for i in range(n)]
    t0 = now()
    for m in msgs:
        pub.publish(m)
    ex.spin_for(0.001)
    dt = (now() - t0) / 1e9
    assert count[0] == n
    return n / dt


def paced(n, period_us, put):
    """Call put(stamp) n times from this thread, sleeping ~period_us in between.

    Sleeping releases the GIL, so the receiving thread can run at once (a busy-wait would
    hold the GIL for up to sys.getswitchinterval() = 5 ms and measure that instead)."""
    pause = period_us * 1e-6
    sleep = time.sleep
    for _ in range(n):
        put(now())
        sleep(pause)


def bus_cross_thread(n, period_us):
    ctx = Context()
    ctx.log_to_stderr = False
    a, b = ctx.create_node("producer"), ctx.create_node("consumer")
    pub = a.create_publisher(Int64, "x", KEEP_ALL)
    lat = []
    done = threading.Event()

    def cb(m):
        lat.append(now() - m.data)
        if len(lat) == n:
            done.set()

    b.create_subscription(Int64, "x", cb, KEEP_ALL)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(b)
    th = threading.Thread(target=paced, args=(n, period_us, lambda t: pub.publish(Int64(data=t))))
    th.start()
    from robocourse.bus import Future

    fut = Future()
    threading.Thread(target=lambda: (done.wait(), fut.set_result(True)), daemon=True).start()
    ex.spin_until_future_complete(fut, timeout_sec=60)
    th.join()
    return pct(lat)


# ------------------------------------------------------------------------------- baselines


def queue_handoff(n, period_us):
    q = queue.Queue()
    lat = []

    def consumer():
        get = q.get
        for _ in range(n):
            t = get()
            lat.append(now() - t)

    th = threading.Thread(target=consumer)
    th.start()
    paced(n, period_us, q.put)
    th.join()
    return pct(lat)


def queue_same_thread(n):
    """queue.Queue put then get on one thread: the cheapest possible hand-off, for msgs/s."""
    q = queue.Queue()
    lat = np.empty(n, dtype=np.int64)
    t0 = now()
    for i in range(n):
        q.put(now())
        lat[i] = now() - q.get()
    dt = (now() - t0) / 1e9
    p50, p99 = pct(lat)
    return p50, p99, n / dt


def zenoh_available():
    try:
        import zenoh  # noqa: F401
    except ImportError:
        return False
    return True


def zenoh_session():
    import zenoh

    conf = zenoh.Config()
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("listen/endpoints", "[]")
    return zenoh.open(conf)


def zenoh_rows(session, n, period_us):
    """Same-session put -> subscriber callback: paced latency and flat-out msgs/s."""
    lat = []
    done = threading.Event()
    target = [n]

    def cb(sample):
        t = now()
        (stamp,) = struct.unpack("<q", sample.payload.to_bytes())
        lat.append(t - stamp)
        if len(lat) >= target[0]:
            done.set()

    sub = session.declare_subscriber("robocourse/bench/lat", cb)
    pub = session.declare_publisher("robocourse/bench/lat")
    paced(n, period_us, lambda t: pub.put(struct.pack("<q", t)))
    done.wait(60)
    paced_p = pct(lat)
    # flat out
    lat.clear()
    done.clear()
    t0 = now()
    for _ in range(n):
        pub.put(struct.pack("<q", now()))
    done.wait(60)
    rate = len(lat) / ((now() - t0) / 1e9)
    flat_p = pct(lat)
    pub.undeclare()
    sub.undeclare()
    return paced_p, flat_p, rate


# ------------------------------------------------------------------------------- CPU


def five_node_graph_cpu(seconds):
    """Sensor -> estimator -> controller -> actuator, plus a logger; sensor timer at 1 kHz."""
    ctx = Context()
    ctx.log_to_stderr = False
    names = ["sensor", "estimator", "controller", "actuator", "logger"]
    nodes = {k: ctx.create_node(k) for k in names}
    raw = nodes["sensor"].create_publisher(Float64MultiArray, "joint_raw", 10)
    est = nodes["estimator"].create_publisher(Float64MultiArray, "joint_est", 10)
    cmd = nodes["controller"].create_publisher(Float64MultiArray, "joint_cmd", 10)
    k = [0]

    def sense():
        k[0] += 1
        raw.publish(Float64MultiArray(data=[0.001 * k[0], 0.0, 0.0]))

    def estimate(m):
        est.publish(Float64MultiArray(data=[m.data[0], m.data[0] * 0.5, 0.0]))

    def control(m):
        cmd.publish(Float64MultiArray(data=[-2.0 * m.data[0] - 0.3 * m.data[1]]))

    applied = [0]
    logged = [0]
    nodes["sensor"].create_timer(0.001, sense)
    nodes["estimator"].create_subscription(Float64MultiArray, "joint_raw", estimate, 10)
    nodes["controller"].create_subscription(Float64MultiArray, "joint_est", control, 10)
    nodes["actuator"].create_subscription(Float64MultiArray, "joint_cmd",
                                          lambda m: applied.__setitem__(0, applied[0] + 1), 10)
    nodes["logger"].create_subscription(Float64MultiArray, "joint_est",
                                        lambda m: logged.__setitem__(0, logged[0] + 1), 10)
    ex = SingleThreadedExecutor(context=ctx)
    for n in nodes.values():
        ex.add_node(n)
    c0, w0 = time.process_time(), time.perf_counter()
    ex.spin_for(seconds)
    c1, w1 = time.process_time(), time.perf_counter()
    return 100.0 * (c1 - c0) / (w1 - w0), k[0], applied[0], logged[0]


# ------------------------------------------------------------------------------- main


def fmt(x, spec):
    return "-" if x != x else spec.format(x)


def run_rows(n_lat, n_cross, period_us, session):
    """One repeat of every row: {name: (p50 us, p99 us, msgs/s wall, CPU us per msg)}."""
    nan = float("nan")
    rows = {}
    rows["bus: same executor (timer -> sub), Int64"] = bus_same_executor(n_lat)
    rows["bus: KEEP_ALL burst delivery, Int64"] = (nan, nan, bus_burst_throughput(n_lat * 2), nan)
    for name, (t, make, field) in SIZED.items():
        n = n_lat // 10 if "100 kB" not in name else max(200, n_lat // 200)
        rows[f"bus: same executor, {name}"] = bus_same_executor_sized(n, t, make, field)
    rows[f"bus: cross-thread publisher ({period_us} us pacing)"] = (*bus_cross_thread(n_cross, period_us), nan, nan)
    rows[f"queue.Queue thread hand-off ({period_us} us pacing)"] = (*queue_handoff(n_cross, period_us), nan, nan)
    rows["queue.Queue put+get, one thread"] = (*queue_same_thread(n_lat), nan)
    if session is not None:
        paced_p, flat_p, zrate = zenoh_rows(session, n_cross, period_us)
        rows[f"zenoh same session put -> callback ({period_us} us pacing)"] = (*paced_p, nan, nan)
        rows["zenoh same session put -> callback (flat out)"] = (*flat_p, zrate, nan)
    return rows


def cpu_runs(secs, k):
    return [five_node_graph_cpu(secs) for _ in range(k)]


def med(values):
    values = [v for v in values if v == v]
    return statistics.median(values) if values else float("nan")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="fewer samples (smoke run)")
    ap.add_argument("--repeats", type=int, default=None)
    ap.add_argument("--lib", default=None, help="robocourse tree to measure (default: this repo's lib/)")
    ap.add_argument("--baseline-lib", default=None,
                    help="another robocourse lib/ to run side by side (interleaved repeats)")
    ap.add_argument("--json", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    reps = args.repeats or (1 if args.quick else 5)
    n_lat = 20_000 if args.quick else 100_000
    n_cross = 5_000 if args.quick else 20_000
    period_us = 50
    have_zenoh = zenoh_available()
    secs = 2.0 if args.quick else 5.0
    if args.json:       # one repeat for a parent run (--baseline-lib)
        rows = run_rows(n_lat, n_cross, period_us, None)
        cpu = cpu_runs(secs, 1)[0][0]
        print(json.dumps({"rows": rows, "cpu": cpu, "copy": copy_costs(2000)}))
        return
    if not have_zenoh:
        print("NOTE: eclipse-zenoh is not installed, so the zenoh baseline is skipped. Install it with:\n"
              "    pip install -r benchmarks/requirements.txt   (eclipse-zenoh==1.10.2)\n")
    import subprocess

    session = zenoh_session() if have_zenoh else None
    new, old, cpu_new, cpu_old = {}, {}, [], []
    for r in range(reps):
        if args.baseline_lib:
            cmd = [sys.executable, os.path.abspath(__file__), "--lib", args.baseline_lib, "--json"]
            if args.quick:
                cmd.append("--quick")
            res = json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)
            for k, v in res["rows"].items():
                old.setdefault(k, []).append(v)
            cpu_old.append(res["cpu"])
        for k, v in run_rows(n_lat, n_cross, period_us, session).items():
            new.setdefault(k, []).append(v)
        cpu_new.append(cpu_runs(secs, 1)[0])
        print(f"repeat {r + 1}/{reps} done", file=sys.stderr)
    if session is not None:
        session.close()

    def summary(rows):
        return {k: tuple(med([x[i] for x in v]) for i in range(4)) for k, v in rows.items()}

    sn, so = summary(new), summary(old)
    base = "bus: same executor (timer -> sub), Int64"
    b50, b99, brate, _ = sn[base]
    print(f"\nrobocourse.bus latency benchmark: {reps} repeats (medians), Python "
          f"{sys.version.split()[0]}, {os.cpu_count()} CPUs, library {LIB}")
    print("The machine is shared and noisy: compare ratios from this one run, not absolute figures.\n")
    hdr = (f"{'path':62s} {'p50 us':>8s} {'p99 us':>8s} {'msgs/s':>10s} {'CPU us/msg':>10s} "
           f"{'p50/bus':>8s} {'p99/bus':>8s}")
    print(hdr)
    print("-" * len(hdr))
    for name, (p50, p99, rate, cpu) in sn.items():
        print(f"{name:62s} {fmt(p50, '{:8.2f}'):>8s} {fmt(p99, '{:8.2f}'):>8s} "
              f"{fmt(rate, '{:10.0f}'):>10s} {fmt(cpu, '{:10.2f}'):>10s} "
              f"{fmt(p50 / b50, '{:8.2f}'):>8s} {fmt(p99 / b99, '{:8.2f}'):>8s}")
    if so:
        print(f"\nOld vs new, same run (baseline library {os.path.abspath(args.baseline_lib)}):\n")
        hdr = (f"{'path':62s} {'old p50':>8s} {'new p50':>8s} {'ratio':>6s} {'old p99':>8s} "
               f"{'new p99':>8s} {'ratio':>6s} {'old msg/s':>10s} {'new msg/s':>10s} "
               f"{'old CPU us':>10s} {'new CPU us':>10s} {'ratio':>6s}")
        print(hdr)
        print("-" * len(hdr))
        for name, (p50, p99, rate, cpu) in sn.items():
            if name not in so or name.startswith(("queue", "zenoh")):
                continue
            o50, o99, orate, ocpu = so[name]
            print(f"{name:62s} {fmt(o50, '{:8.2f}'):>8s} {fmt(p50, '{:8.2f}'):>8s} "
                  f"{fmt(p50 / o50, '{:6.2f}'):>6s} {fmt(o99, '{:8.2f}'):>8s} {fmt(p99, '{:8.2f}'):>8s} "
                  f"{fmt(p99 / o99, '{:6.2f}'):>6s} {fmt(orate, '{:10.0f}'):>10s} {fmt(rate, '{:10.0f}'):>10s} "
                  f"{fmt(ocpu, '{:10.2f}'):>10s} {fmt(cpu, '{:10.2f}'):>10s} {fmt(cpu / ocpu, '{:6.2f}'):>6s}")
    costs = copy_costs(20_000 if not args.quick else 2000)
    print("\nPer-message cost of value semantics (best of 3, us): the generated copy vs rclpy's CDR "
          "serialize + deserialize (mcap_ros2 codec)\n")
    print(f"{'message':40s} {'CDR bytes':>10s} {'copy us':>9s} {'CDR us':>9s} {'CDR/copy':>9s}")
    for name, row in costs.items():
        cp = row.get("copy_us", float("nan"))
        print(f"{name:40s} {row['cdr_bytes']:10d} {fmt(cp, '{:9.2f}'):>9s} {row['cdr_us']:9.2f} "
              f"{fmt(row['cdr_us'] / cp, '{:9.1f}'):>9s}")
    pcts = [c[0] for c in cpu_new]
    print(f"\n1 kHz 5-node graph on the wall clock ({secs:.0f} s x {len(cpu_new)}): CPU "
          f"{statistics.median(pcts):.1f}% of one core (median; runs: "
          f"{', '.join(f'{p:.1f}%' for p in pcts)}); ticks {cpu_new[-1][1]}, commands applied "
          f"{cpu_new[-1][2]}, estimates logged {cpu_new[-1][3]}"
          + (f"; baseline library {statistics.median(cpu_old):.1f}%" if cpu_old else ""))
    js = sn.get("bus: same executor, JointState 7 joints (300 B CDR)", (float("nan"),) * 4)
    print("\nGoals (issue 9): small-message same-executor p50 <= 5 us, p99 <= 15 us, ahead of zenoh "
          "and queue.Queue; JointState(7) p50 <= 15 us; 1 kHz 5-node graph < 10% of one core.")
    print(f"  same-executor Int64 p50 {b50:.2f} us, p99 {b99:.2f} us, {brate:,.0f} msgs/s; "
          f"JointState(7) p50 {js[0]:.2f} us; 5-node graph {statistics.median(pcts):.1f}%")


if __name__ == "__main__":
    main()
