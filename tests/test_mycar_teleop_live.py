"""Live teleop: buttons publish from any thread, the executor spins in the background, the car
moves by the measured amount, the watchdog's stop is reported, the thread ends; static fallback."""

from __future__ import annotations

import re
import threading
import time

import pytest

from robocourse.mycar.teleop_live import LiveTeleop, live_teleop
from robocourse.viz import Scene


def wait_for(cond, timeout=60.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if cond():
            return True
        time.sleep(0.02)
    return False


def stamp(event: str) -> float:
    return float(re.match(r"t=\s*([0-9.]+) s", event).group(1))


def teleop_threads():
    return [t for t in threading.enumerate() if t.name.startswith("robocourse-teleop")]


@pytest.fixture
def tele():
    t = LiveTeleop(scene=Scene(live=False), realtime_factor=4.0)   # 4 simulated s per wall s: a short test
    yield t
    if t.running:
        t.stop()


def test_a_press_drives_the_car_for_the_hold_then_the_watchdog_stops_it(tele):
    tele.start()
    assert tele.running and len(teleop_threads()) == 1
    assert wait_for(lambda: tele.car.driver.odom_published > 5)
    x0 = tele.odometry[0]
    tele.press("w", hold_s=1.0)                    # 0.2 m/s for 1 s of simulated time
    assert wait_for(lambda: any("WATCHDOG" in e for e in tele.events)), tele.events
    assert wait_for(lambda: abs(tele.speed[0]) < 1e-3)
    moved = tele.odometry[0] - x0
    # 1 s at 0.2 m/s, plus up to 0.2 s rolling before the watchdog, minus the wheels' spin-up
    assert 0.15 < moved < 0.26, moved
    assert tele.published >= 9                      # re-published at 10 Hz for the whole hold
    assert tele.watchdog_trips == 1 and "no /cmd_vel" in tele.status
    released = next(e for e in tele.events if "last /cmd_vel" in e)
    tripped = next(e for e in tele.events if "WATCHDOG" in e)
    gap = stamp(tripped) - stamp(released)
    assert 0.2 <= gap <= 0.25                       # the 0.2 s watchdog acted (checked every 10 ms)
    assert tele.executor.callback_errors == []
    tele.stop()
    assert teleop_threads() == [] and not tele.running
    assert tele.node not in tele.executor.get_nodes()


def test_stop_button_stops_on_command_and_presses_from_other_threads_are_safe(tele):
    tele.start()
    presses = [threading.Thread(target=lambda k=k: [tele.press(k, hold_s=30.0) for _ in range(50)]) for k in "wqe"]
    for p in presses:
        p.start()
    for p in presses:
        p.join()
    assert wait_for(lambda: tele.speed[0] > 0.1)
    tele.press("x")
    assert wait_for(lambda: any("WATCHDOG" in e for e in tele.events))
    stop = next(e for e in tele.events if "stop pressed" in e)
    trip = next(e for e in tele.events if "WATCHDOG" in e)
    assert 0.2 <= stamp(trip) - stamp(stop) <= 0.25  # silence after the zero Twist: the watchdog still reports
    assert wait_for(lambda: abs(tele.speed[0]) < 1e-3)
    halted = next(t for t, _x, _y, _yaw, v, _w in tele.history() if t > stamp(stop) and abs(v) < 0.02)
    assert halted - stamp(stop) < 0.15               # braked on the zero command, before the watchdog's 0.2 s
    assert tele.executor.callback_errors == []
    tele.stop()
    assert teleop_threads() == []


def test_the_widget_buttons_drive_the_car(tele):
    ipywidgets = pytest.importorskip("ipywidgets")
    box = tele.widget()
    assert tele.running
    buttons = [w for w in _walk(box) if isinstance(w, ipywidgets.Button)]
    forward = next(b for b in buttons if b.description == "forward")
    assert wait_for(lambda: tele.car.driver.odom_published > 5)
    x0 = tele.odometry[0]
    forward.click()
    assert wait_for(lambda: tele.odometry[0] - x0 > 0.05)
    next(b for b in buttons if b.description == "end teleop").click()
    assert wait_for(lambda: teleop_threads() == [], timeout=10)


def _walk(w):
    yield w
    for c in getattr(w, "children", ()):
        yield from _walk(c)


def test_an_error_in_the_background_is_reported_and_the_thread_ends(tele):
    calls = []

    def broken(wall_s=None):
        calls.append(1)
        if len(calls) > 3:
            raise RuntimeError("injected: the simulator died")
        LiveTeleop.step(tele, wall_s)

    tele.step = broken
    tele.start()
    assert wait_for(lambda: not tele.running)
    assert "injected" in tele.status
    with pytest.raises(RuntimeError, match="teleop thread failed.*injected"):
        tele.stop()
    assert teleop_threads() == []


def test_headless_fallback_records_a_scripted_drive_as_static_html(capsys):
    scene = Scene(live=False)
    tele, view = live_teleop(scene=scene)
    assert not tele.running and teleop_threads() == []
    assert "srcdoc=" in view.data and "127.0.0.1" not in view.data
    assert scene.frames_recorded() > 80
    x, y, _ = tele.odometry
    assert (x * x + y * y) ** 0.5 > 0.4             # the scripted 5 s drive went somewhere
    out = capsys.readouterr().out
    assert "WATCHDOG stopped the car" in out and tele.watchdog_trips == 1
    tele.stop()


def test_bad_settings_are_refused_before_anything_starts():
    with pytest.raises(ValueError, match="rate_hz=4 .*watchdog_timeout"):
        LiveTeleop(scene=Scene(live=False), rate_hz=4)
    with pytest.raises(ValueError, match="hold_s=-1"):
        LiveTeleop(scene=Scene(live=False), hold_s=-1)
    t = LiveTeleop(scene=Scene(live=False))
    with pytest.raises(ValueError, match="unknown teleop key 'z'"):
        t.press("z")
    with pytest.raises(TypeError, match="launched car"):
        LiveTeleop(car=object())


def test_start_refuses_while_another_thread_spins_the_cars_executor(tele):
    from robocourse.bus import Future

    stop = Future()
    th = threading.Thread(target=tele.executor.spin_until_future_complete, args=(stop,), daemon=True)
    th.start()
    try:
        assert wait_for(tele.executor.is_spinning_elsewhere)
        with pytest.raises(RuntimeError, match="already spinning on another thread"):
            tele.start()
        assert not tele.running and teleop_threads() == []
    finally:
        stop.set_result(True)
        tele.executor._wake()
        th.join(10)
    tele.start()                                     # the other thread is gone: the teleop may spin it now
    x0 = tele.odometry[0]
    tele.press("w", hold_s=0.5)
    assert wait_for(lambda: tele.odometry[0] - x0 > 0.02 or tele.error is not None)
    tele.stop()
    assert tele.error is None
