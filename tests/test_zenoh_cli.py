"""The ``robocourse`` CLI against a graph in other processes: ``zenoh router`` (started and
stopped by signals), ``topic list -t``, ``topic info -v``, ``topic echo --once/-n/--timeout``,
``node list``; each run as a subprocess with a timeout, against a talker in a third process."""

import os
import signal
import subprocess
import sys

import pytest
from test_zenoh_processes import _free_port, _peer, _readline, endpoint, spawn  # noqa: F401

CLI = [sys.executable, "-m", "robocourse.cli"]


def _run(*args, timeout=60):
    return subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=timeout,
                          env={**os.environ, "PYTHONUNBUFFERED": "1"})


@pytest.fixture
def talker(endpoint, spawn):  # noqa: F811
    spawn(*_peer("talker", endpoint), "--period", "0.02")
    return endpoint


def test_topic_list_node_list_and_info_see_the_other_process(talker):
    r = _run("topic", "list", "-t", "--connect", talker)
    assert r.returncode == 0, r.stderr
    assert "/chatter [std_msgs/msg/String]" in r.stdout.splitlines()
    assert "_robocourse" not in r.stdout
    r = _run("topic", "list", "--connect", talker)
    assert "/chatter" in r.stdout.splitlines()
    r = _run("node", "list", "--connect", talker)
    assert r.returncode == 0 and r.stdout.split() == ["/talker"], (r.stdout, r.stderr)
    r = _run("topic", "info", "-v", "/chatter", "--connect", talker)
    assert r.returncode == 0, r.stderr
    out = r.stdout
    assert "Type: std_msgs/msg/String" in out and "Publisher count: 1" in out
    assert "Node name: talker" in out and "History (Depth): KEEP_LAST (7)" in out
    assert "Reliability: RELIABLE" in out


def test_topic_echo_once_and_n_stop_by_themselves(talker):
    r = _run("topic", "echo", "/chatter", "--once", "--connect", talker)
    assert r.returncode == 0, r.stderr
    assert r.stdout.count("---") == 1 and r.stdout.startswith("data: hello ")
    r = _run("topic", "echo", "/chatter", "-n", "3", "--connect", talker)
    assert r.returncode == 0, r.stderr
    nums = [int(line.split()[-1]) for line in r.stdout.splitlines() if line.startswith("data")]
    assert len(nums) == 3 and nums == sorted(nums)


def test_topic_echo_on_an_unknown_topic_exits_with_a_reason(endpoint):  # noqa: F811
    r = _run("topic", "echo", "/nobody", "--once", "--connect", endpoint)
    assert r.returncode == 1 and "could not determine the type of '/nobody'" in r.stderr


def test_topic_echo_timeout_when_nothing_is_published(endpoint, spawn):  # noqa: F811
    # a topic that exists (a subscription declares it) but on which nothing is published
    spawn(*_peer("echo", endpoint))
    r = _run("topic", "echo", "/ping", "-n", "1", "--timeout", "0.5", "--connect", endpoint)
    assert r.returncode == 1 and "0 of 1 messages on '/ping' within 0.5 s" in r.stderr


def test_graph_commands_without_a_router_name_the_fix():
    r = _run("node", "list", "--connect", f"tcp/127.0.0.1:{_free_port()}")
    assert r.returncode == 1 and "robocourse zenoh router" in r.stderr
    assert "Traceback" not in r.stderr


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_zenoh_router_serves_then_stops_cleanly_on_a_signal(sig):
    ep = f"tcp/127.0.0.1:{_free_port()}"
    p = subprocess.Popen([*CLI, "zenoh", "router", "--listen", ep], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    try:
        line = _readline(p, 60)
        assert f"listening on {ep}" in line
        r = _run("node", "list", "--connect", ep)          # reachable: no error, empty graph
        assert r.returncode == 0 and r.stdout.strip() == "", r.stderr
        p.send_signal(sig)
        assert p.wait(timeout=20) == 0
        assert "stopped" in p.stdout.read()
    finally:
        if p.poll() is None:
            p.kill()
            p.wait(timeout=10)
        p.stdout.close()
        p.stderr.close()


def test_second_router_on_the_same_port_is_a_clear_error(endpoint):  # noqa: F811
    r = _run("zenoh", "router", "--listen", endpoint, timeout=60)
    assert r.returncode == 1 and "cannot start a zenoh router" in r.stderr
