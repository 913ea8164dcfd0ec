"""robocourse.bus latency, throughput and CPU, side by side with baselines in the same run.

    PYTHONPATH=lib python benchmarks/bus_latency.py [--quick]

Rows:
- bus, same executor: a timer callback publishes a small message (std_msgs/Int64 carrying
  perf_counter_ns), a subscription on the same SingleThreadedExecutor receives it; latency is
  publish -> start of the subscription callback. msgs/s is the whole loop (timer + publish +
  delivery + callback) run flat out.
- bus, cross-thread: a plain thread publishes, the executor spins in the main thread.
- queue.Queue: a thread puts the stamp, another thread get()s it (the classic hand-off).
- zenoh: eclipse-zenoh same-session put -> subscriber callback (benchmark-only dependency:
  pip install -r benchmarks/requirements.txt).
Then the CPU use of a 1 kHz, 5-node graph on the wall clock (process CPU time / wall time).
Every row reports medians over repeats; ratios are relative to the bus same-executor row.
"""

from __future__ import annotations

import argparse
import os
import queue
import statistics
import struct
import sys
import threading
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "lib"))

from robocourse.bus import (  # noqa: E402
    Context,
    HistoryPolicy,
    QoSProfile,
    SingleThreadedExecutor,
)
from robocourse.msgs.std_msgs import Float64MultiArray, Int64  # noqa: E402

now = time.perf_counter_ns
KEEP_ALL = QoSProfile(history=HistoryPolicy.KEEP_ALL)


def pct(lat_ns):
    a = np.asarray(lat_ns, dtype=np.float64) / 1000.0
    return float(np.percentile(a, 50)), float(np.percentile(a, 99))


# ------------------------------------------------------------------------------- bus rows


def bus_same_executor(n):
    """Latency and loop rate: timer (period 0) publishes, subscription receives."""
    ctx = Context()
    ctx.log_to_stderr = False
    a, b = ctx.create_node("talker"), ctx.create_node("listener")
    pub = a.create_publisher(Int64, "lat", 10)
    lat = np.empty(n, dtype=np.int64)
    state = {"i": 0}

    def tick():
        pub.publish(Int64(data=now()))

    from robocourse.bus import Future

    fut = Future()

    def cb(msg):
        t = now()
        i = state["i"]
        if i < n:
            lat[i] = t - msg.data
            state["i"] = i + 1
            if i + 1 == n:
                fut.set_result(True)

    timer = a.create_timer(0.0, tick)
    b.create_subscription(Int64, "lat", cb, 10)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(a)
    ex.add_node(b)
    t0 = now()
    ex.spin_until_future_complete(fut)
    elapsed = (now() - t0) / 1e9
    timer.cancel()
    p50, p99 = pct(lat)
    return p50, p99, n / elapsed


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


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="fewer samples (smoke run)")
    ap.add_argument("--repeats", type=int, default=None)
    args = ap.parse_args(argv)
    reps = args.repeats or (1 if args.quick else 5)
    n_lat = 20_000 if args.quick else 100_000
    n_cross = 5_000 if args.quick else 20_000
    period_us = 50
    have_zenoh = zenoh_available()
    if not have_zenoh:
        print("NOTE: eclipse-zenoh is not installed, so the zenoh baseline is skipped. Install it with:\n"
              "    pip install -r benchmarks/requirements.txt   (eclipse-zenoh==1.10.2)\n")

    rows = {}

    def add(name, p50, p99, rate=None):
        rows.setdefault(name, {"p50": [], "p99": [], "rate": []})
        rows[name]["p50"].append(p50)
        rows[name]["p99"].append(p99)
        if rate is not None:
            rows[name]["rate"].append(rate)

    session = zenoh_session() if have_zenoh else None
    for r in range(reps):
        p50, p99, rate = bus_same_executor(n_lat)
        add("bus: same executor (timer -> sub)", p50, p99, rate)
        rows.setdefault("bus: KEEP_ALL burst delivery", {"p50": [], "p99": [], "rate": []})
        rows["bus: KEEP_ALL burst delivery"]["rate"].append(bus_burst_throughput(n_lat * 2))
        add(f"bus: cross-thread publisher ({period_us} us pacing)", *bus_cross_thread(n_cross, period_us))
        add(f"queue.Queue thread hand-off ({period_us} us pacing)", *queue_handoff(n_cross, period_us))
        add("queue.Queue put+get, one thread", *queue_same_thread(n_lat))
        if session is not None:
            paced_p, flat_p, zrate = zenoh_rows(session, n_cross, period_us)
            add(f"zenoh same session put -> callback ({period_us} us pacing)", *paced_p)
            add("zenoh same session put -> callback (flat out)", *flat_p, zrate)
        print(f"repeat {r + 1}/{reps} done", file=sys.stderr)
    if session is not None:
        session.close()

    base = rows["bus: same executor (timer -> sub)"]
    b50, b99 = statistics.median(base["p50"]), statistics.median(base["p99"])
    brate = statistics.median(base["rate"])
    print(f"\nrobocourse.bus latency benchmark: {reps} repeats (medians), Python "
          f"{sys.version.split()[0]}, {os.cpu_count()} CPUs\n")
    hdr = f"{'path':58s} {'p50 us':>8s} {'p99 us':>8s} {'msgs/s':>10s} {'p50/bus':>8s} {'p99/bus':>8s} {'rate/bus':>9s}"
    print(hdr)
    print("-" * len(hdr))
    for name, v in rows.items():
        p50 = statistics.median(v["p50"]) if v["p50"] else float("nan")
        p99 = statistics.median(v["p99"]) if v["p99"] else float("nan")
        rate = statistics.median(v["rate"]) if v["rate"] else float("nan")
        print(f"{name:58s} {fmt(p50, '{:8.2f}'):>8s} {fmt(p99, '{:8.2f}'):>8s} "
              f"{fmt(rate, '{:10.0f}'):>10s} {fmt(p50 / b50, '{:8.2f}'):>8s} "
              f"{fmt(p99 / b99, '{:8.2f}'):>8s} {fmt(rate / brate, '{:9.2f}'):>9s}")
    secs = 2.0 if args.quick else 5.0
    cpu = [five_node_graph_cpu(secs) for _ in range(1 if args.quick else 3)]
    pcts = [c[0] for c in cpu]
    print(f"\n1 kHz 5-node graph on the wall clock ({secs:.0f} s x {len(cpu)}): CPU "
          f"{statistics.median(pcts):.1f}% of one core (median; runs: "
          f"{', '.join(f'{p:.1f}%' for p in pcts)}); ticks {cpu[-1][1]}, commands applied "
          f"{cpu[-1][2]}, estimates logged {cpu[-1][3]}")
    print("\nGoals (issue 4): same-executor p50 <= 10 us, p99 <= 50 us, >= 200k msgs/s, lower p50/p99 "
          "than both baselines; 1 kHz 5-node graph < 10% of one core.")
    print(f"  same-executor p50 {b50:.2f} us, p99 {b99:.2f} us, {brate:,.0f} msgs/s")


if __name__ == "__main__":
    main()
