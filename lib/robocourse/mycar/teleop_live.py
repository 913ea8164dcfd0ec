"""Drive MyCar live from a notebook: buttons -> /cmd_vel while the executor spins in the background.

Counterpart: ``ros2 run teleop_twist_keyboard teleop_twist_keyboard`` next to a running robot.
A teleop there is its own process publishing at its own pace while the robot's nodes spin in
theirs; here the car's executor runs in a background thread paced to the wall clock (its
simulated clock advances ``realtime_factor`` seconds per wall second), and the buttons only
change *what* is being commanded. All bus work (publishing, callbacks, drawing) happens on that
one thread; the widget callbacks take a lock and set the active command, nothing else, so the
single-threaded bus is never touched from two threads.

The watchdog, made visible: a button press commands its motion for ``hold_s`` seconds, repeated
at ``rate_hz`` (10 Hz, twice as often as the driver's 0.2 s watchdog needs), like holding a key
in teleop_twist_keyboard. When the hold ends the teleop simply stops publishing (it does not send
a zero), so the car keeps its last wheel speeds until the driver's watchdog notices the silence
and stops the motors; the status line shows that moment, the driver's own log line and the
timeout. "stop" sends one zero Twist instead: the car brakes at once, and 0.2 s later the
watchdog still logs its stop, because the driver's watchdog watches for silence, not for motion.

Where widgets cannot render (tests, ``nbconvert --execute``, a plain script) :func:`live_teleop`
drives a scripted sequence of the same presses in simulated time, records it and returns the
recording as static HTML with the same status lines.
"""

from __future__ import annotations

import contextlib
import math
import threading
import time
from collections import deque

from robocourse.bus import QoSProfile, ReliabilityPolicy
from robocourse.msgs.diagnostic_msgs import DiagnosticArray
from robocourse.msgs.geometry_msgs import Twist
from robocourse.msgs.nav_msgs import Odometry

#: button/key -> (label, linear.x m/s, angular.z rad/s); the same motions as teleop.KEYMAP
BUTTONS = {"q": ("curve L", 0.2, 1.0), "w": ("forward", 0.2, 0.0), "e": ("curve R", 0.2, -1.0),
           "a": ("left", 0.0, 1.5), "x": ("stop", 0.0, 0.0), "d": ("right", 0.0, -1.5),
           "s": ("back", -0.2, 0.0)}

#: the fallback's scripted drive: (key, seconds held), then a release the watchdog has to catch
DEMO_SCRIPT = (("w", 1.5), ("q", 2.0), ("e", 1.5))

#: the live view: a square this wide (m) around the car, seen from the -y side 55 deg above the
#: floor (world x runs left to right on screen)
LIVE_VIEW_SQUARE = 0.6
LIVE_VIEW_DIRECTION = (0.0, -math.cos(math.radians(55.0)), math.sin(math.radians(55.0)))


def _yaw(q) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


class LiveTeleop:
    """Buttons that drive a launched MyCar while its executor spins in a background thread.

    ``car``: a :class:`robocourse.mycar.launch.MyCar` (default: ``launch()``); ``scene``: a
    :class:`robocourse.viz.Scene` (default: the notebook's ``get_scene()``); ``rate_hz``: how
    often the active command is re-published; ``hold_s``: how long one press drives;
    ``realtime_factor``: simulated seconds per wall second; ``tick_s``: wall seconds per
    background step (the executor spins ``tick_s * realtime_factor`` simulated seconds per step).
    """

    def __init__(self, car=None, scene=None, *, rate_hz: float = 10.0, hold_s: float = 1.0,
                 realtime_factor: float = 1.0, tick_s: float = 0.02, draw_hz: float = 20.0):
        for name, value in (("rate_hz", rate_hz), ("hold_s", hold_s), ("realtime_factor", realtime_factor),
                            ("tick_s", tick_s), ("draw_hz", draw_hz)):
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (math.isfinite(value) and value > 0):
                raise ValueError(f"LiveTeleop {name}={value!r}: must be a positive number (e.g. rate_hz=10, hold_s=1.0)")
        if car is None:
            from .launch import launch

            car = launch()
        for attr in ("context", "executor", "driver"):
            if not hasattr(car, attr):
                raise TypeError(f"LiveTeleop needs a launched car (robocourse.mycar.launch.launch()), got {car!r} "
                                f"without .{attr}")
        self.car, self.ctx, self.executor = car, car.context, car.executor
        self.rate_hz, self.hold_s, self.realtime_factor, self.tick_s = float(rate_hz), float(hold_s), float(realtime_factor), float(tick_s)
        self.watchdog_timeout = float(car.driver.get_parameter("watchdog_timeout").value)
        if 1.0 / self.rate_hz >= self.watchdog_timeout:
            raise ValueError(f"rate_hz={rate_hz} repeats the command every {1e3 / rate_hz:.0f} ms, not faster than the "
                             f"driver's watchdog_timeout ({self.watchdog_timeout * 1e3:.0f} ms): the watchdog would stop "
                             f"the car between repeats; use rate_hz > {1 / self.watchdog_timeout:.0f}")
        self._lock = threading.Lock()
        self._active: tuple[str, float, float] | None = None   # (key, v, w) being published
        self._until_ns = 0                                     # sim time when the hold ends
        self._zero_pending = False
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.error: BaseException | None = None
        self.events: list[str] = []                           # what happened, oldest first (the status history)
        self.status = "not started: call start() (or use live_teleop())"
        self.published = 0
        self._last_pub_ns = 0
        self.odometry = (0.0, 0.0, 0.0)                        # x, y, yaw from /odom
        self.speed = (0.0, 0.0)                                # v, w from /odom
        self._history: deque = deque(maxlen=20_000)             # (t, x, y, yaw, v, w) per /odom message
        self.watchdog_trips = 0
        self._seen_logs = len(self.ctx.log_records)
        self.node = self.ctx.create_node("teleop_live")
        self.pub = self.node.create_publisher(Twist, "/cmd_vel", QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE))
        self.node.create_subscription(Odometry, "/odom", self._on_odom,
                                      QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT))
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, 10)
        self.node.create_timer(1.0 / self.rate_hz, self._on_timer)
        self.executor.add_node(self.node)
        self._scene, self._drawer, self._draw_every = scene, None, max(1, round(1.0 / (draw_hz * self.tick_s)))
        self._framed_at = None
        self.recording = None                                  # the last drive_recorded(): a view.CarRecording

    # -- what the buttons do (any thread) ------------------------------------------------------
    def press(self, key: str, hold_s: float | None = None) -> None:
        """Command the motion of ``key`` for ``hold_s`` (default ``self.hold_s``) simulated seconds,
        re-published at ``rate_hz``; "x" (stop) publishes one zero Twist and ends any hold."""
        if key not in BUTTONS:
            raise ValueError(f"unknown teleop key {key!r}; keys: " + ", ".join(f"{k} {v[0]}" for k, v in BUTTONS.items()))
        hold = self.hold_s if hold_s is None else float(hold_s)
        if not (math.isfinite(hold) and hold > 0):
            raise ValueError(f"hold_s={hold_s!r} must be a positive number of seconds")
        label, v, w = BUTTONS[key]
        with self._lock:
            if key == "x":
                self._active, self._zero_pending = None, True
            else:
                self._active = (label, v, w)
                self._until_ns = self._now_ns() + int(hold * 1e9)

    def release(self) -> None:
        """Stop publishing now (no zero command): the watchdog is what stops the car."""
        with self._lock:
            self._until_ns = 0

    def _now_ns(self) -> int:
        return self.node.get_clock().now().nanoseconds

    # -- callbacks (executor thread) -----------------------------------------------------------
    def _on_timer(self) -> None:
        now = self._now_ns()
        with self._lock:
            zero, self._zero_pending = self._zero_pending, False
            active = self._active if self._active is not None and now < self._until_ns else None
            ended = self._active is not None and active is None
            if ended:
                self._active = None
        msg = Twist()
        if zero:
            self.pub.publish(msg)
            self.published += 1
            self._last_pub_ns = now
            self._event(now, "stop pressed: one zero Twist sent, the car brakes on command; /cmd_vel is silent "
                             "from now on, so the driver's watchdog will still report a stop (it cannot tell "
                             "that the last command was zero)")
        if active is not None:
            label, msg.linear.x, msg.angular.z = active
            self.pub.publish(msg)
            self.published += 1
            self._last_pub_ns = now
            self.status = (f"{label}: /cmd_vel linear.x={msg.linear.x:+.2f} m/s angular.z={msg.angular.z:+.2f} rad/s "
                           f"every {1e3 / self.rate_hz:.0f} ms, faster than the {self.watchdog_timeout * 1e3:.0f} ms "
                           "watchdog, so the motors stay on")
        elif ended:
            self._event(self._last_pub_ns, f"hold over: that was the last /cmd_vel; the car rolls on its last command until the driver's "
                             f"watchdog sees {self.watchdog_timeout * 1e3:.0f} ms of silence")

    def _on_odom(self, msg: Odometry) -> None:
        p = msg.pose.pose
        self.odometry = (p.position.x, p.position.y, _yaw(p.orientation))
        self.speed = (msg.twist.twist.linear.x, msg.twist.twist.angular.z)
        st = msg.header.stamp
        with self._lock:
            self._history.append((st.sec + st.nanosec * 1e-9, *self.odometry, *self.speed))

    def history(self) -> list[tuple[float, float, float, float, float, float]]:
        """(t s, x m, y m, yaw rad, v m/s, w rad/s) of every /odom message so far (a copy, any thread)."""
        with self._lock:
            return list(self._history)

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        for st in msg.status:
            for kv in st.values:
                if kv.key == "watchdog_trips" and kv.value.isdigit():
                    self.watchdog_trips = max(self.watchdog_trips, int(kv.value))

    def _check_driver_log(self) -> None:
        """The driver's own WARN line is the watchdog event (what ``ros2 run`` would print)."""
        records = self.ctx.log_records
        new, self._seen_logs = records[self._seen_logs:], len(records)
        for rec in new:
            text = rec.msg.lower()
            if rec.name != self.node.get_name() and rec.severity == 30 and any(
                    word in text for word in ("watchdog", "emergency", "no /cmd_vel")):
                self.watchdog_trips += 1
                self._event(rec.stamp_ns, f"WATCHDOG stopped the car: [{rec.name}] \"{rec.msg}\" (timeout "
                                          f"{self.watchdog_timeout * 1e3:.0f} ms). Press a button to drive again.")

    def _event(self, stamp_ns: int, text: str) -> None:
        line = f"t={stamp_ns * 1e-9:7.2f} s  {text}"
        self.events.append(line)
        self.status = text

    # -- the background loop ---------------------------------------------------------------------
    def step(self, wall_s: float | None = None) -> None:
        """One background step: spin the executor ``wall_s * realtime_factor`` seconds, draw."""
        dt = (self.tick_s if wall_s is None else float(wall_s)) * self.realtime_factor
        self.executor.spin_for(dt)
        self._check_driver_log()

    def _loop(self) -> None:
        sim = self.ctx.sim is not None
        next_t = time.monotonic()
        k = 0
        try:
            while not self._stop.is_set() and self.ctx.ok():
                self.step()
                k += 1
                if k % self._draw_every == 0:
                    self.draw()
                if sim:  # simulated time runs as fast as the callbacks: hold it to the wall clock
                    next_t += self.tick_s
                    delay = next_t - time.monotonic()
                    if delay > 0:
                        self._stop.wait(delay)
                    elif delay < -1.0:
                        next_t = time.monotonic()  # fell behind (a loaded machine): do not try to catch up
        except BaseException as exc:  # noqa: BLE001 - reported on the status line and re-raised by stop()
            self.error = exc
            self.status = f"stopped by an error in the background thread: {exc!r}"

    def start(self) -> LiveTeleop:
        """Start spinning the car's executor in a background thread (wall-clock paced)."""
        if self._thread is not None and self._thread.is_alive():
            return self
        if self.executor.is_spinning_elsewhere():
            raise RuntimeError("the car's executor is already spinning on another thread; stop that first "
                               "(one executor, one spinning thread, as in rclpy)")
        self._stop.clear()
        self.status = "running: press a button"
        self._thread = threading.Thread(target=self._loop, name="robocourse-teleop-live", daemon=True)
        self._thread.start()
        return self

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def stop(self, timeout: float = 10.0) -> None:
        """Stop the background thread (the car is left stopped: one zero Twist) and remove the node."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout)
            if self._thread.is_alive():
                raise RuntimeError(f"the teleop thread did not stop within {timeout} s (a callback is stuck?)")
            self._thread = None
        with self._lock:
            self._active = None
        if self.node in self.executor.get_nodes():
            self.pub.publish(Twist())
            self.executor.spin_for(0.05)
            self.executor.remove_node(self.node)
            self.node.destroy_node()
        self.status = "stopped"
        if self.error is not None:
            err, self.error = self.error, None
            raise RuntimeError(f"the teleop thread failed: {err!r}") from err

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.stop()

    # -- the 3D view -----------------------------------------------------------------------------
    @property
    def scene(self):
        if self._scene is None:
            from robocourse.viz import get_scene

            self._scene = get_scene()
        return self._scene

    @contextlib.contextmanager
    def _live_direction(self):
        """Frame the live view from :data:`LIVE_VIEW_DIRECTION`; a later recording frames itself."""
        kept, self.scene.view_direction = self.scene.view_direction, LIVE_VIEW_DIRECTION
        try:
            yield
        finally:
            self.scene.view_direction = kept

    def draw(self) -> None:
        """Draw the car in the live view as it is now (the background loop calls this at ``draw_hz``).

        The camera frames a :data:`LIVE_VIEW_SQUARE` m square around the car and re-frames when
        the car has moved a quarter of it (a camera that follows in steps: each re-frame is one
        command to the viewer), so the car keeps its size on screen wherever it drives."""
        sim = getattr(self.car, "simulator", None)
        if sim is None:
            return
        if self._drawer is None:
            from .view import fresh_drawer

            self._drawer = fresh_drawer(self.scene, self.car)   # an earlier recording is not framed
        self._drawer.update(sim.car.data)
        x, y, _ = sim.car.pose()
        half = LIVE_VIEW_SQUARE / 2
        if self._framed_at is None or math.hypot(x - self._framed_at[0], y - self._framed_at[1]) > half / 2:
            self._framed_at = (x, y)
            from .view import FRAME_PATH

            for name, dx, dy in (("a", -half, -half), ("b", half, half), ("c", -half, half), ("d", half, -half)):
                self.scene.sphere(f"{FRAME_PATH}/{name}", 0.001, rgba=(1, 1, 1, 0.0))
                self.scene.set_pose(f"{FRAME_PATH}/{name}", (x + dx, y + dy, 0.0))
            if self.scene.camera_auto:
                with self._live_direction():
                    self.scene.frame()

    # -- notebook front ends ------------------------------------------------------------------------
    def widget(self, height: int = 380):
        """ipywidgets: the button pad, the status line, the event log and the live 3D view."""
        import ipywidgets as widgets
        from IPython.display import display

        status = widgets.HTML(value=self.status)
        log = widgets.Textarea(value="", layout=widgets.Layout(width="100%", height="90px"), disabled=True)
        odom = widgets.HTML()

        def button(key):
            label = BUTTONS[key][0]
            b = widgets.Button(description=label, layout=widgets.Layout(width="80px"),
                               button_style="danger" if key == "x" else "")
            b.on_click(lambda _b: self.press(key))
            return b

        pad = widgets.VBox([widgets.HBox([button(k) for k in "qwe"]), widgets.HBox([button(k) for k in "axd"]),
                            widgets.HBox([button("s")])])
        hold = widgets.FloatSlider(value=self.hold_s, min=0.2, max=5.0, step=0.1, description="hold [s]")
        hold.observe(lambda ch: setattr(self, "hold_s", float(ch["new"])), names="value")
        quit_b = widgets.Button(description="end teleop", button_style="warning")
        view = widgets.Output()
        with view, self._live_direction():
            self.draw()
            display(self.scene.show(height=height))

        def refresh():
            while self.running:
                status.value = f"<b>{self.status}</b>"
                x, y, yaw = self.odometry
                odom.value = (f"/odom: x={x:+.3f} m y={y:+.3f} m yaw={math.degrees(yaw):+.0f} deg, "
                              f"v={self.speed[0]:+.2f} m/s; watchdog trips {self.watchdog_trips}")
                log.value = "\n".join(self.events[-6:])
                time.sleep(0.2)
            status.value = f"<b>{self.status}</b>"

        quit_b.on_click(lambda _b: self.stop())
        self.start()
        threading.Thread(target=refresh, name="robocourse-teleop-status", daemon=True).start()
        return widgets.VBox([widgets.HBox([pad, widgets.VBox([hold, quit_b])]), status, odom, log, view])

    def drive_recorded(self, script=DEMO_SCRIPT, height: int = 380, settle_s: float = 1.0):
        """The static fallback: press ``script``'s buttons in simulated time (no thread), record the
        drive and return it as static HTML; the events list says what the watchdog did."""
        if self.running:
            raise RuntimeError("drive_recorded() while the live thread runs: stop() it first")
        from .view import CarRecording

        fps = 20
        rec = self.recording = CarRecording(self.car, self.scene, fps=fps)
        rec.sample()

        def run(seconds):
            for _ in range(max(1, round(seconds * fps))):
                self.step(1.0 / fps / self.realtime_factor)
                rec.sample()

        for key, seconds in script:
            self.press(key, hold_s=seconds + 1.0 / self.rate_hz)   # overlaps the next press, as a held key does
            run(seconds)
        run(self.watchdog_timeout + settle_s)     # released: the watchdog has to stop the car
        return rec.finish(height)


def live_teleop(car=None, scene=None, script=DEMO_SCRIPT, **kwargs):
    """Live buttons in a notebook a person is looking at; a recorded scripted drive elsewhere.

    Returns ``(teleop, view)``: ``view`` is the widget (live) or the static recording, and
    ``teleop.events`` lists what happened (including the watchdog's stop)."""
    from robocourse.viz import get_scene

    scene = scene if scene is not None else get_scene()
    teleop = LiveTeleop(car, scene, **kwargs)
    if scene.live:
        return teleop, teleop.widget()
    view = teleop.drive_recorded(script)
    for line in teleop.events:
        print(line)
    return teleop, view
