"""ROS 2 naming rules and expansion."""

import pytest

from robocourse.bus import Context, InvalidNameError
from robocourse.bus.names import (
    InvalidNamespaceException,
    InvalidNodeNameException,
    InvalidServiceNameException,
    InvalidTopicNameException,
    expand_topic_name,
)
from robocourse.msgs.std_msgs import Float64


@pytest.mark.parametrize("name,ns,node,expected", [
    ("chatter", "/", "talker", "/chatter"),
    ("chatter", "/robot1", "talker", "/robot1/chatter"),
    ("/chatter", "/robot1", "talker", "/chatter"),
    ("~", "/robot1", "talker", "/robot1/talker"),
    ("~/status", "/robot1", "talker", "/robot1/talker/status"),
    ("~/status", "/", "talker", "/talker/status"),
    ("a/b/c", "/ns", "n", "/ns/a/b/c"),
    ("{node}/out", "/ns", "n", "/ns/n/out"),
])
def test_expansion_like_rcl(name, ns, node, expected):
    assert expand_topic_name(name, node, ns) == expected


@pytest.mark.parametrize("bad", ["", "/", "chat//ter", "chatter/", "1abc", "a/2b", "ch-atter",
                                 "a~b", "~x", "with space", "/bad!"])
def test_malformed_topic_names_raise_with_the_name(bad):
    with pytest.raises(InvalidTopicNameException) as e:
        expand_topic_name(bad, "n", "/")
    assert repr(bad) in str(e.value) or bad == ""


def test_malformed_names_at_node_level():
    ctx = Context()
    for bad in ("", "1node", "my-node", "ns/node", "a b"):
        with pytest.raises(InvalidNodeNameException):
            ctx.create_node(bad)
    for bad in ("/ns/", "//x", "/1x", "/a-b"):
        with pytest.raises(InvalidNamespaceException):
            ctx.create_node("ok", namespace=bad)
    node = ctx.create_node("ok", namespace="robot")     # relative namespace gets a leading '/'
    assert node.get_fully_qualified_name() == "/robot/ok"
    with pytest.raises(InvalidTopicNameException, match="must not end"):
        node.create_publisher(Float64, "x/", 10)
    with pytest.raises(InvalidServiceNameException):
        node.resolve_service_name("bad name")
    assert issubclass(InvalidTopicNameException, InvalidNameError)
    assert issubclass(InvalidNameError, ValueError)


def test_private_and_relative_topics_resolve_on_the_node():
    ctx = Context()
    node = ctx.create_node("driver", namespace="/car")
    p1 = node.create_publisher(Float64, "~/temp", 10)
    p2 = node.create_publisher(Float64, "speed", 10)
    assert (p1.topic_name, p2.topic_name) == ("/car/driver/temp", "/car/speed")
