"""The session configuration a Context gets: loopback by default, every interface once it
connects to another machine (the one option for two machines), and the sim-time warning."""

import socket
import time

import pytest

from robocourse.bus.context import Context
from robocourse.bus.executors import SingleThreadedExecutor
from robocourse.bus.logging import LoggingSeverity
from robocourse.bus.zenoh.processes import free_router
from robocourse.bus.zenoh.transport import (
    LISTEN_ALL,
    LISTEN_LOOPBACK,
    default_listen,
    is_loopback,
)
from robocourse.msgs.std_msgs import Int32


@pytest.mark.parametrize("endpoint, loopback", [
    ("tcp/127.0.0.1:7447", True), ("tcp/127.0.1.1:7447", True), ("tcp/localhost:7447", True),
    ("tcp/[::1]:7447", True), ("udp/127.0.0.1:7447", True),
    ("tcp/192.168.1.42:7447", False), ("tcp/10.0.0.7:7447", False), ("tcp/[fe80::1]:7447", False),
    ("tcp/robot.local:7447", False), ("tcp/0.0.0.0:7447", False),
])
def test_is_loopback(endpoint, loopback):
    assert is_loopback(endpoint) is loopback


def test_default_listen_follows_the_connect_endpoints():
    assert default_listen("peer", ["tcp/127.0.0.1:7447"]) == [LISTEN_LOOPBACK] == ["tcp/127.0.0.1:0"]
    assert default_listen("peer", ["tcp/192.168.1.42:7447"]) == [LISTEN_ALL] == ["tcp/0.0.0.0:0"]
    # one remote router among several is enough: peers there must reach us directly
    assert default_listen("peer", ["tcp/127.0.0.1:7447", "tcp/robot.local:7447"]) == [LISTEN_ALL]
    assert default_listen("client", ["tcp/192.168.1.42:7447"]) == []


def _lan_address():
    """This machine's address on its default route (no packet is sent), or None."""
    for target in ("192.0.2.1", "10.254.254.254"):       # TEST-NET / private: never contacted
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            try:
                s.connect((target, 9))
            except OSError:
                continue
            addr = s.getsockname()[0]
        if not addr.startswith("127.") and addr != "0.0.0.0":
            return addr
    return None


def test_two_machine_configuration_with_one_option():
    """The router listens on every interface; a context that connects through the machine's
    LAN address (as machine B would) listens on every interface by itself; one that connects
    over loopback (a node on machine A) stays on loopback; and they talk."""
    lan = _lan_address()
    if lan is None:
        pytest.skip("this machine has no non-loopback IPv4 address to stand in for a LAN")
    r, ep = free_router("0.0.0.0")
    port = ep.rsplit(":", 1)[1]
    b = Context(transport="zenoh", connect=[f"tcp/{lan}:{port}"])           # the one option
    a = Context(transport="zenoh", connect=[f"tcp/127.0.0.1:{port}"])
    explicit = Context(transport="zenoh", connect=[f"tcp/{lan}:{port}"],
                       listen=["tcp/127.0.0.1:0"])
    try:
        assert b.transport.listen == ["tcp/0.0.0.0:0"]
        assert a.transport.listen == ["tcp/127.0.0.1:0"]
        assert explicit.transport.listen == ["tcp/127.0.0.1:0"]             # listen= still wins
        pub = b.create_node("on_b").create_publisher(Int32, "/lan", 10)
        node = a.create_node("on_a")
        got = []
        node.create_subscription(Int32, "/lan", lambda m: got.append(m.data), 10)
        assert b.transport.wait_for(lambda t: any(e.topic == "/lan" for e in t.remote_entities("MS")))
        ex = SingleThreadedExecutor(context=a)
        ex.add_node(node)
        end = time.monotonic() + 10
        i = 0
        while len(got) < 5 and time.monotonic() < end:
            pub.publish(Int32(data=i))
            i += 1
            ex.spin_once(timeout_sec=0.02)
        assert len(got) >= 5 and got == sorted(got)
    finally:
        for c in (a, b, explicit):
            c.try_shutdown()
        r.close()


def test_sim_time_with_the_zenoh_transport_warns_once_with_the_fix():
    r, ep = free_router()
    sim = Context(use_sim_time=True, transport="zenoh", connect=[ep])
    wall = Context(transport="zenoh", connect=[ep])
    try:
        sim.log_to_stderr = False
        sim.create_node("a")
        sim.create_node("b")                    # more nodes: still the one warning
        warned = [rec for rec in sim.log_records if rec.name == "zenoh_transport"]
        assert len(warned) == 1 and warned[0].severity == LoggingSeverity.WARN
        text = warned[0].msg
        assert "simulated time stays in this process" in text
        assert "wall time (ns since 1970)" in text and "Fix:" in text
        assert not [rec for rec in wall.log_records if rec.name == "zenoh_transport"]
    finally:
        sim.try_shutdown()
        wall.try_shutdown()
        r.close()
