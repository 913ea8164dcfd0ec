"""What the process boundary costs: the in-process bus vs robocourse over zenoh vs raw zenoh,
and the chapter 2 pendulum graph split across two processes at 1 kHz. Same run, same payloads.

    .venv/bin/python benchmarks/zenoh_transport.py [--repeats 5] [--n 1000] [--quick]
    .venv/bin/python benchmarks/zenoh_transport.py --stages [--n 2000]

A zenoh router runs in this process on a free loopback port (rmw_zenoh's defaults: peers,
multicast scouting off). Rows:

- latency: ping-pong round trips (publish on /ping -> an echo republishes on /pong -> back),
  one message in flight, p50/p99 of the round trip in microseconds. Payload
  ``std_msgs/String`` as CDR: "small" (20 characters, 29 B with the encapsulation header and
  length) and "1 kB" (1012 characters, 1021 B); the table prints both sizes.
  * in-process bus: the echo node on the same Context and executor (no serialization);
  * robocourse/zenoh: the echo is ``python -m robocourse.bus.zenoh.peer echo`` in another
    process; each side puts CDR + the 33-byte attachment on rmw_zenoh's keys;
  * raw + hand-off: plain eclipse-zenoh as below, but on both sides zenoh's callback hands
    the sample to another thread through a lock (what a SingleThreadedExecutor's wake-up
    costs, with no codec and no node layer); this isolates the hand-off rclpy's semantics
    require (a subscription callback runs on the spinning thread, not in zenoh's);
  * raw zenoh: a plain eclipse-zenoh echo process (this file, ``--role raw-echo``) and plain
    ``put``/subscriber callbacks on two keys carrying the same CDR bytes, answered and timed
    inside zenoh's callbacks: the floor.
- throughput: N messages published back to back (RELIABLE + KEEP_ALL, so zenoh blocks
  instead of dropping), msgs/s until the N-th echo is back (a round trip per message,
  pipelined).
- pendulum: ``pendulum_motor`` (physics thread, sensor every ``demo.MOTOR_PERIOD_NS``) and
  ``pendulum_controller`` (PID, command every ``demo.CONTROLLER_PERIOD_NS``) with the seed's
  topics and QoS (BEST_EFFORT, KEEP_LAST 1), for ``--seconds`` each, in one process and then
  split across two processes; the setpoint moves (a 0.5 rad, 0.5 Hz sine) so the pendulum
  keeps moving. A message is *late* if its one-way latency (publish -> subscription callback,
  wall clock, same machine) exceeds the 1 ms control period, or if it never arrives. Messages
  are matched by value (every sensor state and PID command is a distinct float).

Every row is the median over ``--repeats`` interleaved repeats, with the min..max spread.
Ratios are the median [min..max] of per-repeat ratios (the paths of one repeat ran back to
back, so load hits them alike): robocourse/zenoh over raw zenoh (the goal is p50 <= 1.5x),
split into the hand-off's share (raw + hand-off / raw) and robocourse's layers' share
(robocourse / raw + hand-off). The machine is shared: only same-run ratios compare.

Example output of one run (``--repeats 5 --n 500 --flood 2000 --seconds 3``, 2026-11 branch
s3-zperf, a shared 2-core box under other engineers' load; one run's figures, not a
specification):

    round trip (publish -> echo in the other process -> back), microseconds; median [min..max] over repeats
    payload  path                                 p50 us                     p99 us                     msgs/s
    small (29 B) in-process bus               6.2 [6.1..6.2]            7.9 [6.6..12.6] 152,212 [142,978..154,410]
    small (29 B) robocourse/zenoh       317.4 [312.3..334.0]       390.0 [381.3..486.5]    45,025 [40,022..62,223]
    small (29 B) raw + hand-off         210.0 [185.4..219.0]       274.5 [262.3..310.7] 273,951 [266,896..295,779]
    small (29 B) raw zenoh              181.0 [173.7..191.5]       240.5 [232.0..276.5] 297,969 [181,961..332,125]
      small: robocourse/zenoh p50 = 1.74x [1.66..1.92] raw zenoh (median of per-repeat ratios [min..max]; goal <= 1.5x: NOT met)
        = 1.16x [1.07..1.21] for the two thread hand-offs alone (raw + hand-off / raw) x 1.49x [1.44..1.80] for robocourse's layers (robocourse / raw + hand-off); 51.3x the in-process bus; throughput 0.16x [0.15..0.27] raw zenoh
    1 kB (1021 B) in-process bus               6.2 [6.2..6.2]             7.7 [6.7..9.2] 151,769 [148,921..152,780]
    1 kB (1021 B) robocourse/zenoh       323.2 [294.5..345.2]       411.4 [383.5..451.1]    55,867 [36,366..59,258]
    1 kB (1021 B) raw + hand-off         209.0 [203.3..211.3]       274.8 [269.5..276.0] 214,846 [212,694..239,282]
    1 kB (1021 B) raw zenoh              180.7 [171.7..185.2]       236.2 [227.7..264.3] 282,392 [214,712..322,860]
      1 kB: robocourse/zenoh p50 = 1.76x [1.61..2.01] raw zenoh (median of per-repeat ratios [min..max]; goal <= 1.5x: NOT met)
        = 1.15x [1.10..1.22] for the two thread hand-offs alone (raw + hand-off / raw) x 1.53x [1.41..1.64] for robocourse's layers (robocourse / raw + hand-off); 52.3x the in-process bus; throughput 0.21x [0.13..0.25] raw zenoh

    pendulum graph at 1 kHz for 3 s: late = one-way latency > 1 ms or lost (sensor + command messages); median [min..max] over repeats
    graph                          late %            sensor p50 us              sensor p99 us             command p99 us  messages
    one process            0.0 [0.0..0.0]           5.9 [5.7..6.2]          18.2 [13.0..25.0]          19.7 [15.1..30.7]      6208
    two processes          0.2 [0.1..0.3]     200.0 [172.5..204.7]       383.3 [295.3..401.3]       377.9 [302.4..399.8]      6217
      two processes: 0.21 % late (goal < 1 %: met)

    stages of one hop in the echo process (small String, 2000 round trips), p50 us
      zenoh callback: attachment access + check        3.6
      payload to bytes                                 0.6
      mcap_ros2 CDR decode                             9.8
      build the message (field checks)                 3.0
      queue + wake the executor                        8.6
      executor thread wakes, takes the message        12.6
      callback -> publish -> sender                    2.6
      mcap_ros2 CDR encode                            11.4
      attachment                                       1.0
      zenoh put call                                  19.6
      whole hop: zenoh callback -> put returns        81.2
      zenoh: client put -> echo callback             106.7
      zenoh: echo put -> client callback              99.4
      round trip (client publish -> callback)        325.4

(the stage table is a separate ``--stages --n 2000`` run, same day; its stamps add ~0.2 us
each, and medians of stages do not add up to the median of the whole hop.)

The goal (robocourse within 1.5x of raw zenoh's p50) is NOT met: 1.74x (small) and 1.76x
(1 kB) in that run; meeting it there would need the round trip at 271 us instead of 317, i.e.
~46 us less. Where robocourse's ~136 us over raw zenoh go (small: 317.4 - 181.0), from the
two runs above:

- the two thread hand-offs, ~29 us (raw + hand-off - raw: 210.0 - 181.0). In robocourse they
  are "queue + wake" and "executor thread wakes", 8.6 + 12.6 us per hop, ~42 us per round
  trip, so the executor's wake path costs ~13 us per round trip more than a bare lock
  hand-off. rclpy's rule that callbacks run on the spinning thread needs the hand-off.
- mcap_ros2's CDR codec, ~48 us per round trip (decode 9.8 + build 3.0 + encode 11.4 per
  hop, x 2). In a warm loop the same decode takes 1.5 us and the encode 2.4 us: the
  ping-pong path runs with cold caches, so every Python step costs 4-6x its warm time.
- rmw_zenoh's attachment, ~9 us per round trip in Python (3.6 + 1.0 per hop) plus carrying
  33 more bytes per sample in zenoh (the zenoh legs, 106.7 / 99.4 us one way, include it).
- the publish layers (callback -> publish -> sender), ~5 us per round trip.

This round changed no hot path: the two candidates measured did not pay off. (1) Running
the transport's sample callback directly in zenoh's network thread
(``handlers.Callback(..., indirect=False)``, removing zenoh-python's own Python-thread hop;
user callbacks would still run on the executor) was slower in a quick run (p50 2.93x raw
vs 1.86x in the run before it, throughput halved): the network thread has to take the GIL
for every sample. (2) Handing the zenoh sender the publisher's message instead of a copy
(the CDR bytes are the snapshot) made no measurable difference (interleaved quick runs,
small p50 324.8 / 314.8 us before vs 332.9 / 331.4 us after): a String copy is ~0.15 us.
What could reach the goal is the codec: a code-generating CDR library (e.g. rosbags' serde)
instead of mcap_ros2's interpreted one is the next thing to try; it is a new dependency, so
not done here. Throughput is limited by the same per-message Python work (~0.2x raw
zenoh). The pendulum split holds its goal (< 1 % late).

Stages (``--stages [--n 2000]``): one robocourse ping-pong with timing probes in both
processes (``perf_counter_ns``, CLOCK_MONOTONIC, so stamps compare across processes on one
machine): the p50 of each stage of the echo's hop and of the two zenoh legs.
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
HANDOFF_PING, HANDOFF_PONG = "bench/handoff/ping", "bench/handoff/pong"
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


class _Handoff:
    """What an executor adds to a raw zenoh callback, and nothing else: the callback queues the
    item and releases a lock (SingleThreadedExecutor's wake-up); another thread, blocked on
    that lock, takes the item and runs ``work(item)``."""

    def __init__(self, work):
        import collections

        self.queue, self.work = collections.deque(), work
        self.signal = threading.Lock()
        self.signal.acquire()
        threading.Thread(target=self._loop, daemon=True).start()

    def __call__(self, item):
        self.queue.append(item)
        try:
            self.signal.release()
        except RuntimeError:        # already signalled
            pass

    def _loop(self):
        while True:
            self.signal.acquire()
            while self.queue:
                self.work(self.queue.popleft())


def raw_echo(endpoint, handoff=False):
    """The raw zenoh echo process: every sample on RAW_PING is put back on RAW_PONG from
    zenoh's callback; with ``handoff``, HANDOFF_PING -> HANDOFF_PONG from another thread."""
    import zenoh

    s = zenoh.open(_config(endpoint))
    ping, pong = (HANDOFF_PING, HANDOFF_PONG) if handoff else (RAW_PING, RAW_PONG)
    pub = s.declare_publisher(pong, congestion_control=zenoh.CongestionControl.BLOCK,
                              reliability=zenoh.Reliability.RELIABLE)
    if handoff:
        later = _Handoff(pub.put)
        s.declare_subscriber(ping, lambda sample: later(sample.payload.to_bytes()))
    else:
        s.declare_subscriber(ping, lambda sample: pub.put(sample.payload))
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
    """Plain puts and a subscriber. The arrival time is taken in zenoh's callback, or, with
    ``handoff``, in the thread that the callback hands the sample to (as a subscription's
    callback runs on the executor's thread)."""

    def __init__(self, endpoint, handoff=False):
        import zenoh

        self.s = zenoh.open(_config(endpoint))
        ping, pong = (HANDOFF_PING, HANDOFF_PONG) if handoff else (RAW_PING, RAW_PONG)
        self.pub = self.s.declare_publisher(ping,
                                            congestion_control=zenoh.CongestionControl.BLOCK,
                                            reliability=zenoh.Reliability.RELIABLE)
        self.cv = threading.Condition()
        self.got = 0
        self.t_recv = 0
        on_pong = _Handoff(self._on_pong) if handoff else self._on_pong
        self.sub = self.s.declare_subscriber(pong, on_pong)

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


# ------------------------------------------------------------------------------ stage probe
STAGES = ("rx_enter", "rx_attachment", "rx_payload", "rx_decoded", "rx_queued",
          "cb_start", "send", "encoded", "put_enter", "put_return")


def _install_stage_probes(stamps):
    """Time each stage of robocourse's hop in this process: ``stamps[stage]`` gets one
    ``perf_counter_ns`` (CLOCK_MONOTONIC: comparable across processes on one machine) per
    message. The zenoh callback and the sender are the transport's own steps with a stamp
    between each (the probes add ~0.2 us per stamp); the executor's ``_run`` is wrapped."""
    from robocourse.bus import executors
    from robocourse.bus.zenoh import transport, wire

    def stamp(k, now=time.perf_counter_ns):
        stamps[k].append(now())

    def on_sample(self, sub):
        dec, ok = wire.decoder(sub.msg_type), wire.attachment_ok

        def probe(sample):
            stamp("rx_enter")
            good = ok(sample.attachment.to_bytes())
            stamp("rx_attachment")
            data = sample.payload.to_bytes()
            stamp("rx_payload")
            m = dec(data)
            stamp("rx_decoded")
            if good:
                sub._deliver(m)
            stamp("rx_queued")
        return probe

    def sender(self, loc):
        put, seq, enc = loc.zobj.put, loc.seq, wire.encoder(loc.t)
        attach, now = wire.attachment_packer(loc.gid), time.time_ns

        def probe(msg):
            stamp("send")
            data = enc(msg)
            stamp("encoded")
            att = attach(next(seq), now())
            stamp("put_enter")
            put(data, attachment=att)
            stamp("put_return")
        return probe

    run = executors.Executor._run

    def run_probe(self, ent, work):
        stamp("cb_start")
        run(self, ent, work)

    transport.ZenohTransport._on_sample = on_sample
    transport.ZenohTransport._sender = sender
    executors.Executor._run = run_probe


def stage_echo(endpoint, out):
    """The robocourse echo (as ``peer echo``) with stage probes; writes its stamps to ``out``."""
    from robocourse.bus import Context, HistoryPolicy, QoSProfile, SingleThreadedExecutor
    from robocourse.msgs.std_msgs import String

    stamps = {k: [] for k in STAGES}
    _install_stage_probes(stamps)
    ctx = Context(transport="zenoh", connect=[endpoint])
    qos = QoSProfile(depth=7, history=HistoryPolicy.KEEP_ALL)
    node = ctx.create_node("echo")
    pub = node.create_publisher(String, "/pong", qos)
    node.create_subscription(String, "/ping", pub.publish, qos)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    print("READY", flush=True)
    closed = threading.Event()
    threading.Thread(target=lambda: (sys.stdin.read(), closed.set()), daemon=True).start()
    while not closed.is_set():
        ex.spin_once(timeout_sec=0.1)
    ctx.try_shutdown()
    with open(out, "w") as f:
        json.dump(stamps, f)


def stages(n):
    """One robocourse ping-pong of ``n`` small messages with both sides probed: the p50 of
    each stage of one hop in the echo process, and the round trip."""
    from robocourse.bus import Context
    from robocourse.bus.zenoh.transport import router

    stamps = {k: [] for k in STAGES}
    _install_stage_probes(stamps)
    ep = f"tcp/127.0.0.1:{_free_port()}"
    r = router([ep])
    out = os.path.join(tempfile.mkdtemp(prefix="zstages_"), "echo.json")
    echo = _spawn([__file__, "--role", "stage-echo", "--connect", ep, "--out", out])
    ctx = Context(transport="zenoh", connect=[ep])
    side = BusSide(ctx, local_echo=False)
    ctx.transport.wait_for(lambda t: len([e for e in t.remote_entities("MS")
                                          if e.topic == "/ping"]) == 1, 20)
    time.sleep(0.5)
    rtt = side.pingpong(_payload("small"), n + 100)[100:]
    echo.stdin.close()
    echo.wait(timeout=20)
    ctx.try_shutdown()
    r.close()
    with open(out) as f:
        e = {k: np.asarray(v[-n:], dtype=float) for k, v in json.load(f).items()}
    c = {k: np.asarray(v[-n:], dtype=float) for k, v in stamps.items()}

    def p50(a, b):
        return float(np.median(b - a)) / 1e3

    print(f"stages of one hop in the echo process (small String, {n} round trips), p50 us")
    rows = [("zenoh callback: attachment access + check", "rx_enter", "rx_attachment"),
            ("payload to bytes", "rx_attachment", "rx_payload"),
            ("CDR decode into the message (field checks)", "rx_payload", "rx_decoded"),
            ("queue + wake the executor", "rx_decoded", "rx_queued"),
            ("executor thread wakes, takes the message", "rx_queued", "cb_start"),
            ("callback -> publish -> sender", "cb_start", "send"),
            ("CDR encode", "send", "encoded"),
            ("attachment", "encoded", "put_enter"),
            ("zenoh put call", "put_enter", "put_return")]
    for label, a, b in rows:
        print(f"  {label:44} {p50(e[a], e[b]):7.1f}")
    print(f"  {'whole hop: zenoh callback -> put returns':44} {p50(e['rx_enter'], e['put_return']):7.1f}")
    print(f"  {'zenoh: client put -> echo callback':44} {p50(c['put_enter'], e['rx_enter']):7.1f}")
    print(f"  {'zenoh: echo put -> client callback':44} {p50(e['put_enter'], c['rx_enter']):7.1f}")
    print(f"  {'round trip (client publish -> callback)':44} {float(np.median(rtt)) / 1e3:7.1f}")


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


def fmt(t, unit="", digits=1):
    m, lo, hi = t
    if m >= 1000:
        return f"{m:,.0f}{unit} [{lo:,.0f}..{hi:,.0f}]"
    return f"{m:.{digits}f}{unit} [{lo:.{digits}f}..{hi:.{digits}f}]"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--role", choices=["raw-echo", "handoff-echo", "motor", "controller",
                                       "stage-echo"])
    ap.add_argument("--connect")
    ap.add_argument("--out")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--n", type=int, default=1000, help="round trips per row and repeat")
    ap.add_argument("--flood", type=int, default=5000, help="messages per throughput run")
    ap.add_argument("--seconds", type=float, default=5.0, help="pendulum run length")
    ap.add_argument("--quick", action="store_true", help="3 repeats, fewer messages")
    ap.add_argument("--stages", action="store_true",
                    help="only time each stage of a robocourse hop (probes in both processes)")
    a = ap.parse_args()
    if a.role == "stage-echo":
        return stage_echo(a.connect, a.out)
    if a.stages:
        return stages(a.n)
    if a.role in ("raw-echo", "handoff-echo"):
        return raw_echo(a.connect, handoff=a.role == "handoff-echo")
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
             _spawn([__file__, "--role", "raw-echo", "--connect", ep]),
             _spawn([__file__, "--role", "handoff-echo", "--connect", ep])]
    inproc = BusSide(Context(), local_echo=True)
    zctx = Context(transport="zenoh", connect=[ep])
    rc = BusSide(zctx, local_echo=False)
    zctx.transport.wait_for(lambda t: len([e for e in t.remote_entities("MS")
                                           if e.topic == "/ping"]) == 1, 20)
    raw, handoff = RawSide(ep), RawSide(ep, handoff=True)
    time.sleep(0.5)
    rows = {}                       # (size, path) -> {"p50": [], "p99": [], "tput": []}
    paths = ("in-process bus", "robocourse/zenoh", "raw + hand-off", "raw zenoh")
    print(f"# {a.repeats} repeats x {a.n} round trips, {a.flood}-message floods; router {ep}",
          flush=True)
    for rep in range(a.repeats):
        for size in SIZES:
            msg = _payload(size)
            cdr = wire.to_cdr(msg)
            order = list(paths) if rep % 2 == 0 else list(reversed(paths))
            for path in order:
                side = {"in-process bus": inproc, "robocourse/zenoh": rc, "raw zenoh": raw,
                        "raw + hand-off": handoff}[path]
                item = cdr if path.startswith("raw") else msg
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
    handoff.s.close()
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
        def ratio(num, den, key="p50", size=size):
            """median [min..max] of the per-repeat ratios (each repeat's paths ran together)"""
            return med([x / y for x, y in zip(rows[(size, num)][key], rows[(size, den)][key])])

        vs_raw, vs_handoff = ratio("robocourse/zenoh", "raw zenoh"), \
            ratio("robocourse/zenoh", "raw + hand-off")
        handoff_cost = ratio("raw + hand-off", "raw zenoh")
        in50 = med(rows[(size, "in-process bus")]["p50"])[0]
        rc50 = med(rows[(size, "robocourse/zenoh")]["p50"])[0]
        tput = ratio("robocourse/zenoh", "raw zenoh", "tput")
        print(f"  {size}: robocourse/zenoh p50 = {fmt(vs_raw, 'x', 2)} raw zenoh (median of "
              f"per-repeat ratios [min..max]; goal <= 1.5x: "
              f"{'met' if vs_raw[0] <= 1.5 else 'NOT met'})\n"
              f"    = {fmt(handoff_cost, 'x', 2)} for the two thread hand-offs alone (raw + "
              f"hand-off / raw) x {fmt(vs_handoff, 'x', 2)} for robocourse's layers (robocourse / "
              f"raw + hand-off); {rc50 / in50:.1f}x the in-process bus; throughput "
              f"{fmt(tput, 'x', 2)} raw zenoh")
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
