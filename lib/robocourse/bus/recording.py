"""Recording to MCAP (ROS 2 message definitions, opens in Foxglove), reading back, replay.

ROS 2 counterpart: ``ros2 bag record -s mcap`` / ``ros2 bag play`` (rosbag2). Files are
written with ``mcap_ros2.writer.Writer``: one schema per type (``ros2msg`` encoding, the .msg
text with nested definitions appended) and CDR-encoded messages, so any ROS 2 tool reads them.

Typical notebook use::

    rec = record(ctx, "run.mcap", ["/x", "/cmd"])   # hidden node, KEEP_ALL subscriptions
    executor.spin_for(10.0)
    rec.close()
    data = read_recording("run.mcap").to_numpy("/x")   # {"t": seconds, "data": ...}

Log times are the recorder node's clock (simulated time when the context uses it), so a
simulated run gives the same file contents every time.
"""

from __future__ import annotations

import functools
import itertools
import os

import numpy as np

from robocourse.bus import _args
from robocourse.bus.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from robocourse.msgs import definition_name, from_dict, full_definition, get_message_type, to_numpy
from robocourse.msgs._core import wire_view

_ids = itertools.count()


@functools.cache
def _attach(node, ctx, executor) -> None:
    """Spin ``node`` on ``executor``, or on the first executor already spinning ``ctx``."""
    if executor is not None:
        executor.add_node(node)
        return
    for ex in list(ctx._executors):
        ex.add_node(node)
        break


def _context_of(context, what):
    """A Context, or the context of a Node."""
    from robocourse.bus.context import Context

    ctx = context.context if hasattr(context, "get_fully_qualified_name") else context
    if not isinstance(ctx, Context):
        raise TypeError(f"{what} needs a Context or a Node, got {context!r:.80}; e.g. "
                        f"{what}(ctx, ...) with ctx = Context(use_sim_time=True)")
    return ctx


def _check_topics(topics, what):
    if topics is None:
        return
    if isinstance(topics, str) or not all(isinstance(x, str) for x in topics):
        raise TypeError(f"{what}: topics={topics!r} must be a list of topic names such as "
                        f"['/cmd_vel'], or None for every topic")


def _encoder(msg_type):
    from mcap_ros2._dynamic import serialize_dynamic

    name = definition_name(msg_type._type)
    encode = serialize_dynamic(name, full_definition(msg_type))[name]
    return lambda msg: encode(wire_view(msg))


class Recorder:
    """Record topics of a context into an MCAP file (a hidden ``_recorder`` node).

    ``topics=None`` records every topic that exists now and every topic that appears later.
    Subscriptions are KEEP_ALL and adapt reliability/durability to the publishers (like
    rosbag2), so nothing is lost and latched topics are captured.
    """

    def __init__(self, context, path, topics=None, *, executor=None):
        from mcap_ros2.writer import Writer

        from robocourse.bus.node import Node

        ctx = _context_of(context, "record")
        _check_topics(topics, "record")
        if not isinstance(path, (str, os.PathLike)):
            raise TypeError(f"record: path={path!r} must be a file path (str or pathlib.Path), "
                            f"e.g. 'run.mcap'")
        self.context = ctx
        self.path = str(path)
        self._file = open(self.path, "wb")
        self._writer = Writer(self._file)
        self._schemas = {}
        self.node = Node(f"_recorder_{next(_ids)}", context=ctx)
        self.counts: dict[str, int] = {}
        self._subs = {}
        self._all = topics is None
        self._wanted = set(topics or [])
        self._closed = False
        self._seq = 0
        for name in sorted(self._wanted) if not self._all else []:
            if name not in ctx._topics or not (ctx._topics[name].pubs or ctx._topics[name].subs):
                raise ValueError(f"cannot record {name!r}: no such topic yet; create its publisher "
                                 f"first (known topics: {sorted(ctx._topics)})")
        self._refresh()
        ctx.add_graph_listener(self._refresh)
        _attach(self.node, ctx, executor)

    def _refresh(self):
        if self._closed:
            return
        ctx = self.context
        for name, t in list(ctx._topics.items()):
            if name in self._subs or not t.pubs:
                continue
            if not self._all and name not in self._wanted:
                continue
            if any(p._node is self.node for p in t.pubs):
                continue
            self._subscribe(name, t.msg_type, t.pubs)

    def _subscribe(self, name, msg_type, pubs):
        latched = all(p.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in pubs)
        qos = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.BEST_EFFORT,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)
        if msg_type not in self._schemas:
            schema_name = msg_type._type if "_" not in msg_type._type.rsplit("/", 1)[1] \
                else definition_name(msg_type._type)
            self._schemas[msg_type] = self._writer.register_msgdef(schema_name, full_definition(msg_type))
        schema = self._schemas[msg_type]
        clock = self.node.get_clock()
        writer = self._writer
        self.counts[name] = 0

        def write(msg, name=name, schema=schema):
            t = clock._now_ns()
            self._seq += 1
            writer.write_message(name, schema, wire_view(msg), log_time=t, publish_time=t, sequence=self._seq)
            self.counts[name] += 1

        # claim the name before subscribing: create_subscription tells the graph listeners (this
        # _refresh among them), and an unclaimed name would be subscribed again, recursively
        self._subs[name] = None
        self._subs[name] = self.node.create_subscription(msg_type, name, write, qos)

    def close(self) -> str:
        """Stop recording, finish the file, return its path."""
        if self._closed:
            return self.path
        self._closed = True
        self.context.remove_graph_listener(self._refresh)
        self.node.destroy_node()
        self._writer.finish()
        self._file.close()
        return self.path

    stop = close

    def read(self) -> Recording:
        """Close the file (if still recording) and read it back: ``rec.read().to_numpy("/x")``."""
        return Recording(self.close())

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def record(context, path, topics=None, *, executor=None) -> Recorder:
    """Start recording ``topics`` (None: all) of ``context`` to ``path``."""
    return Recorder(context, path, topics, executor=executor)


class Recording:
    """An MCAP file read back: ``.topics``, ``.messages(topic)``, ``.to_numpy(topic)``."""

    def __init__(self, path):
        from mcap.reader import make_reader
        from mcap_ros2.decoder import DecoderFactory

        self.path = str(path)
        self._by_topic: dict[str, list] = {}
        self.types: dict[str, type] = {}
        self.entries = []
        with open(self.path, "rb") as f:
            reader = make_reader(f, decoder_factories=[DecoderFactory()])
            for schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=True):
                topic = channel.topic
                if topic not in self.types:
                    self.types[topic] = get_message_type(schema.name)
                msg = from_dict(self.types[topic], decoded)
                self.entries.append((message.log_time, topic, msg))
                self._by_topic.setdefault(topic, []).append((message.log_time, msg))

    @property
    def topics(self) -> list[str]:
        return sorted(self._by_topic)

    def messages(self, topic: str) -> list:
        """[(log_time_ns, message)] for one topic, in log time order."""
        try:
            return list(self._by_topic[topic])
        except KeyError:
            raise KeyError(f"{topic!r} is not in {self.path}; topics: {self.topics}") from None

    def to_numpy(self, topic: str) -> dict[str, np.ndarray]:
        """``{"t": log time in s, "<field.path>": array, ...}`` for plotting."""
        rows = self.messages(topic)
        out = {"t": np.array([t for t, _ in rows], dtype=np.int64) / 1e9}
        out.update(to_numpy([m for _, m in rows], self.types[topic]))
        return out

    def __len__(self):
        return len(self.entries)

    def __repr__(self):
        return f"<Recording {self.path}: " + ", ".join(
            f"{t} ({len(v)})" for t, v in sorted(self._by_topic.items())) + ">"


def read_recording(path) -> Recording:
    return Recording(path)


class Player:
    """Replay a recording into a graph (``ros2 bag play``): a hidden node publishes each
    message when the node clock reaches its recorded time (offset so the first message goes
    out ``delay`` seconds after ``play`` is created). Spin the executor to play."""

    def __init__(self, recording, context, *, topics=None, rate: float = 1.0, delay: float = 0.0,
                 remap: dict | None = None, qos=None, executor=None):
        from robocourse.bus.node import Node

        if isinstance(rate, bool) or not isinstance(rate, (int, float)) or not rate > 0:
            raise ValueError(f"replay: rate={rate!r} must be a number > 0 (1.0 = recorded speed)")
        _args.seconds(delay, "replay(delay)", name="delay")
        _check_topics(topics, "replay")
        ctx = _context_of(context, "replay")
        if isinstance(recording, (str, bytes)) or hasattr(recording, "__fspath__"):
            recording = Recording(recording)
        self.node = Node(f"_player_{next(_ids)}", context=ctx)
        remap = remap or {}
        entries = [e for e in recording.entries if topics is None or e[1] in topics]
        self._pubs = {}
        for topic in sorted({e[1] for e in entries}):
            self._pubs[topic] = self.node.create_publisher(
                recording.types[topic], remap.get(topic, topic), qos or QoSProfile(depth=1000))
        self._entries = entries
        self._i = 0
        self.published = 0
        clock = self.node.get_clock()
        t0 = entries[0][0] if entries else 0
        start = clock._now_ns() + int(delay * 1e9)
        self._due = [start + int((t - t0) / rate) for t, _, _ in entries]
        self._timer = None
        if entries:
            self._timer = self.node.create_timer(0.0, self._tick)
            self._timer._next_ns = self._due[0]
        _attach(self.node, ctx, executor)

    def _tick(self):
        now = self.node.get_clock()._now_ns()
        while self._i < len(self._entries) and self._due[self._i] <= now:
            _, topic, msg = self._entries[self._i]
            self._pubs[topic].publish(msg)
            self._i += 1
            self.published += 1
        if self._i < len(self._entries):
            self._timer._next_ns = self._due[self._i]
        else:
            self._timer.cancel()

    @property
    def done(self) -> bool:
        return self._i >= len(self._entries)

    def close(self):
        self.node.destroy_node()


def replay(recording, context, **kwargs) -> Player:
    """Start replaying ``recording`` (a path or Recording) into ``context``."""
    return Player(recording, context, **kwargs)
