"""Two processes over zenoh: topics, services, discovery and each fault (subprocesses with
timeouts, always killed). The plain peer (tests/zenoh_raw_peer.py) knows rmw_zenoh's format
from the reference only and decodes with mcap_ros2, independently of robocourse."""

import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from robocourse.bus import introspection as ros2
from robocourse.bus.context import Context
from robocourse.bus.executors import SingleThreadedExecutor
from robocourse.bus.zenoh.processes import free_router
from robocourse.msgs.example_interfaces import AddTwoInts
from robocourse.msgs.std_msgs import String

RAW = Path(__file__).with_name("zenoh_raw_peer.py")
STRING_HASH = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def endpoint():
    r, ep = free_router()
    yield ep
    r.close()


@pytest.fixture
def spawn():
    procs = []

    def start(*args):
        p = subprocess.Popen([sys.executable, *args], stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             env={**os.environ, "PYTHONUNBUFFERED": "1"})
        procs.append(p)
        line = _readline(p, 60)
        assert "READY" in line or "ready" in line, (line, p.stderr.read() if p.poll() else "")
        return p
    yield start
    for p in procs:
        if p.poll() is None:
            p.kill()
        p.wait(timeout=10)
        for f in (p.stdin, p.stdout, p.stderr):
            f.close()


def _readline(p, timeout):
    import select

    r, _, _ = select.select([p.stdout], [], [], timeout)
    assert r, f"no output from {p.args} within {timeout} s"
    return p.stdout.readline()


def _peer(role, ep):
    return ["-m", "robocourse.bus.zenoh.peer", role, "--connect", ep]


def _spin_until(ex, cond, timeout=60.0):
    """Spin until ``cond()``; the timeout is a safety net for a loaded machine, not a timing."""
    end = time.monotonic() + timeout
    while time.monotonic() < end and not cond():
        ex.spin_once(timeout_sec=0.02)
    return cond()


@pytest.fixture
def ctx(endpoint):
    c = Context(transport="zenoh", connect=[endpoint])
    yield c
    c.try_shutdown()


def test_topic_from_another_process_arrives_in_order_with_values(ctx, endpoint, spawn):
    spawn(*_peer("talker", endpoint))
    node = ctx.create_node("listener")
    got = []
    node.create_subscription(String, "/chatter", lambda m: got.append(m), 10)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    assert _spin_until(ex, lambda: len(got) >= 20)
    nums = [int(m.data.split()[1]) for m in got]
    assert nums == sorted(nums) and len(set(nums)) == len(nums)   # RELIABLE: in order, once
    assert all(type(m) is String for m in got)
    assert len({id(m) for m in got}) == len(got)                  # each its own value


def test_remote_nodes_and_endpoints_appear_in_the_graph_with_qos(ctx, endpoint, spawn):
    spawn(*_peer("talker", endpoint))
    assert ctx.transport.wait_for(
        lambda t: any(e.topic == "/add_two_ints" for e in t.remote_entities("SS")), 20)
    # the talker's node also serves its parameter services, as a ROS 2 node does
    assert ctx.transport.wait_for(
        lambda t: any(e.topic == "/talker/get_parameters" for e in t.remote_entities("SS")), 20)
    assert "/talker" in ros2.node_list(ctx, quiet=True)
    assert ("/chatter", ["std_msgs/msg/String"]) in ros2.topic_list(ctx, quiet=True)
    assert ("/add_two_ints", ["example_interfaces/srv/AddTwoInts"]) in \
        ros2.service_list(ctx, quiet=True)
    info = ros2.topic_info(ctx, "/chatter", verbose=True, quiet=True)
    [p] = info["publishers"]
    assert (p["node_name"], p["qos"].depth, p["entity"].type_hash) == ("talker", 7, STRING_HASH)


def test_killed_process_disappears_from_the_graph_and_the_stream_stops(ctx, endpoint, spawn):
    proc = spawn(*_peer("talker", endpoint))
    node = ctx.create_node("listener")
    got = []
    node.create_subscription(String, "/chatter", lambda m: got.append(m.data), 10)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    assert _spin_until(ex, lambda: len(got) >= 5)
    proc.kill()                                                    # mid-stream, no cleanup
    proc.wait(timeout=10)
    assert ctx.transport.wait_for(lambda t: not t.remote_entities(), 20)
    assert "/talker" not in ros2.node_list(ctx, quiet=True)
    _spin_until(ex, lambda: False, 0.3)
    n = len(got)
    _spin_until(ex, lambda: False, 0.3)
    assert len(got) == n and ctx.ok()


def test_service_in_another_process_answers(ctx, endpoint, spawn):
    spawn(*_peer("talker", endpoint))
    node = ctx.create_node("caller")
    cli = node.create_client(AddTwoInts, "/add_two_ints")
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    assert cli.wait_for_service(20)
    futs = [cli.call_async(AddTwoInts.Request(a=i, b=100)) for i in range(3)]
    assert _spin_until(ex, lambda: all(f.done() for f in futs))
    assert [f.result().sum for f in futs] == [100, 101, 102]


def test_plain_zenoh_peer_talks_rmw_zenoh_bytes_both_ways(ctx, endpoint, spawn):
    raw = spawn(str(RAW), "talk", endpoint)
    node = ctx.create_node("listener")
    got = []
    node.create_subscription(String, "/chatter", lambda m: got.append(m.data), 10)
    pub = node.create_publisher(String, "/heard", 10)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    assert _spin_until(ex, lambda: len(got) >= 3)
    assert got[0].startswith("raw ")
    assert "/raw_talker" in ros2.node_list(ctx, quiet=True)
    for i in range(3):
        pub.publish(String(data=f"ours {i}"))
        time.sleep(0.05)
    heard = json.loads(_readline(raw, 10))
    assert heard["heard"].startswith("ours ") and heard["attlen"] == 33 and heard["gidlen"] == 16
    assert heard["head"] == "00010000" and heard["seq"] >= 1


def test_plain_zenoh_client_gets_its_sequence_number_and_gid_back(ctx, endpoint, spawn):
    node = ctx.create_node("add_two_ints_server")

    def add(req, resp):
        resp.sum = req.a + req.b
        return resp
    node.create_service(AddTwoInts, "/add_two_ints", add)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    raw = spawn(str(RAW), "call", endpoint)
    replies = []
    done = _spin_until(ex, lambda: _poll_line(raw, replies) and len(replies) == 3)
    assert done, f"the raw client reported only {replies} within 60 s"
    bad, replies = replies[0], replies[1:]
    # a request that is not AddTwoInts in CDR gets an error reply naming why, and is counted
    assert "does not decode" in bad["truncated_request_error"], bad
    assert ctx.transport.dropped_undecodable == 1
    assert [(r["sum"], r["seq"], r["gid_echoed"]) for r in replies] == \
        [(42, 41, True), (43, 42, True)], replies
    assert replies[0]["key"].startswith("0/add_two_ints/example_interfaces::srv::dds_::")


_PENDING: dict[int, str] = {}


def _poll_line(p, into):
    """Append every complete JSON line the process has written so far. Reads the pipe's fd directly: a
    buffered readline after select() leaves a second line that arrived with the first in Python's buffer,
    where select() never sees it (the third reply was then 'never' read)."""
    import os
    import select

    fd = p.stdout.fileno()
    while select.select([fd], [], [], 0)[0]:
        chunk = os.read(fd, 65536).decode()
        if not chunk:
            break
        _PENDING[fd] = _PENDING.get(fd, "") + chunk
    *lines, _PENDING[fd] = _PENDING.get(fd, "").split("\n")
    into.extend(json.loads(line) for line in lines if line.strip())
    return True


def test_faults_missing_attachment_undecodable_dropped_other_hash_warned_bad_token_counted(
        ctx, endpoint, spawn):
    node = ctx.create_node("listener")
    got = []
    node.create_subscription(String, "/chatter", lambda m: got.append(m.data), 10)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    spawn(str(RAW), "faults", endpoint)
    t = ctx.transport
    assert _spin_until(ex, lambda: t.dropped_no_attachment >= 10 and t.mismatches
                       and t.malformed_tokens and t.dropped_undecodable >= 20)
    assert got == []          # neither the bare, the other-hash nor the undecodable samples
    undecodable = [r.msg for r in ctx.log_records if "transport.dropped_undecodable" in r.msg]
    assert len(undecodable) == 1 and "std_msgs/msg/String" in undecodable[0], undecodable
    assert "never communicate" in t.mismatches[0] and "RIHS01_000" in t.mismatches[0]
    assert "unknown entity kind" in t.malformed_tokens[0][1]
    assert any("never communicate" in r.msg for r in ctx.log_records)


def test_no_router_reachable_is_a_clear_error_with_the_fix():
    with pytest.raises(ConnectionError, match="robocourse zenoh router"):
        Context(transport="zenoh", connect=[f"tcp/127.0.0.1:{_free_port()}"],
                connect_timeout=0.5)


@pytest.mark.parametrize("kwargs, exc, match", [
    ({"transport": "dds"}, ValueError, "only transport is 'zenoh'"),
    ({"domain_id": 0}, TypeError, "without transport='zenoh'"),
    ({"transport": "zenoh", "domain_id": -1}, ValueError, "domain_id=-1"),
    ({"transport": "zenoh", "connect": "tcp/127.0.0.1:7447"}, ValueError, "list of zenoh"),
])
def test_bad_transport_arguments_are_refused(kwargs, exc, match):
    with pytest.raises(exc, match=match):
        Context(**kwargs)
