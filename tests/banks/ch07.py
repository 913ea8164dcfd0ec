"""Chapter 7's answer bank: plausible wrong answers (one per stated property) and correct ones.

Every answer runs in the student's place in the grading sandbox; the reference is the solution
notebook's cell (robocourse.grading.bank). The node exercise runs each answer in a real child
process against the scripted peer.
"""

from robocourse.grading.bank import Answer, Exercise

NB = "07_graph_across_processes_exercises"

ATTACHMENT = Exercise(
    "ch07.attachment", NB,
    right=[Answer("struct with explicit checks", code='''
import struct

def parse_attachment(data):
    data = bytes(data)
    if len(data) != 33:
        raise ValueError(f"attachment of {len(data)} bytes, expected 33")
    seq, stamp, length = struct.unpack_from("<qqB", data)
    if length != 16:
        raise ValueError(f"GID length byte {length}, expected 16 (33 bytes in all)")
    return {"sequence_number": seq, "source_timestamp_ns": stamp, "gid": data[17:33].hex()}
''')],
    wrong=[
        Answer("unsigned sequence number", replace=[('seq_no = int.from_bytes(raw[:8], "little", signed=True)',
                                                     'seq_no = int.from_bytes(raw[:8], "little")')],
               score=1.5, property="the sequence number is an int64 (signed)", says="signed=True"),
        Answer("unsigned timestamp", replace=[('stamp_ns = int.from_bytes(raw[8:16], "little", signed=True)',
                                               'stamp_ns = int.from_bytes(raw[8:16], "little")')],
               score=1.5, property="the source timestamp is an int64 (signed)", says="source_timestamp_ns"),
        Answer("big-endian", replace=[('int.from_bytes(raw[:8], "little", signed=True)',
                                       'int.from_bytes(raw[:8], "big", signed=True)'),
                                      ('int.from_bytes(raw[8:16], "little", signed=True)',
                                       'int.from_bytes(raw[8:16], "big", signed=True)')],
               score=1.0, property="little-endian integers", says="little-endian"),
        Answer("the GID with its length byte", replace=[('"gid": raw[17:].hex()', '"gid": raw[16:32].hex()')],
               score=1.5, property="the GID is the last 16 bytes", says="after the 0x10 length byte"),
        Answer("no length check", replace=[('if len(raw) != 33 or raw[16] != 0x10:', 'if len(raw) < 17:')],
               score=1.5, property="anything but the 33-byte form is refused", says="must raise ValueError"),
        Answer("struct without checks (struct.error, not ValueError)", code='''
import struct

def parse_attachment(data):
    seq, stamp, _n, gid = struct.unpack("<qqB16s", bytes(data))
    return {"sequence_number": seq, "source_timestamp_ns": stamp, "gid": gid.hex()}
''', score={"sequence_number: int64, little-endian, signed": 0.5,
            "source_timestamp_ns: int64, little-endian, signed": 0.5,
            "gid: the last 16 bytes, as 32 lowercase hex characters": 0.5},
               property="a wrong form raises ValueError naming the length", says="must raise ValueError"),
    ])

KEY = Exercise(
    "ch07.key_expression", NB,
    right=[Answer("f-string with strip", code='''
def key_expression(domain_id, topic, type_name, type_hash):
    package, kind, name = type_name.split("/")
    return f"{domain_id}/{topic.strip('/')}/{package}::{kind}::dds_::{name}_/{type_hash}"
''')],
    wrong=[
        Answer("keeps the leading slash", replace=[('name = topic[1:] if topic.startswith("/") else topic',
                                                    'name = topic')],
               score=1.0, property="the name without its leading '/'", says="without its leading '/'"),
        Answer("mangles inner slashes", replace=[('name = name[:-1] if name.endswith("/") else name',
                                                  'name = (name[:-1] if name.endswith("/") else name).replace("/", "%")')],
               score=1.0, property="inner '/' kept", says="inner '/' stay"),
        Answer("services written as msg", replace=[('f"{package}::{kind}::dds_::{short}_"',
                                                    'f"{package}::msg::dds_::{short}_"')],
               score=1.0, property="srv kept for services", says="keeps msg or srv"),
        Answer("no trailing underscore", replace=[('f"{package}::{kind}::dds_::{short}_"',
                                                   'f"{package}::{kind}::dds_::{short}"')],
               score=1.0, property="the DDS type name ends with '_'", says="ends with '_'"),
    ])

HASH = Exercise(
    "ch07.type_hash", NB,
    right=[Answer("hashlib.new", code='''
import hashlib
import json


def rihs01(description):
    digest = hashlib.new("sha256", json.dumps(description).encode()).hexdigest()
    return f"RIHS01_{digest}"
''')],
    wrong=[
        Answer("compact separators", replace=[("text = json.dumps(description)",
                                               'text = json.dumps(description, separators=(",", ":"))')],
               score=0.25, property="json.dumps's default separators", says="default separators"),
        Answer("sorted keys", replace=[("text = json.dumps(description)", "text = json.dumps(description, sort_keys=True)")],
               score=0.25, property="keys in the given order", says="keys in the given order"),
        Answer("no prefix", replace=[('return "RIHS01_" + hashlib', "return hashlib")],
               score=0.75, property="the RIHS01_ prefix", says="starts with 'RIHS01_'"),
        Answer("sha1", replace=[("hashlib.sha256(", "hashlib.sha1(")], score=0.25,
               property="SHA-256", says="sha256 of json.dumps"),
    ])

QOS = Exercise(
    "ch07.qos_connects", NB,
    right=[Answer("a table of the refused pairs", code='''
REFUSED = {("BEST_EFFORT", "RELIABLE"), ("VOLATILE", "TRANSIENT_LOCAL")}

def connects(pub_qos, sub_qos, across_processes):
    asked = {(pub_qos.reliability.name, sub_qos.reliability.name), (pub_qos.durability.name, sub_qos.durability.name)}
    return across_processes or not (asked & REFUSED)
''')],
    wrong=[
        Answer("DDS rules across processes too", replace=[("        return True            # rmw_zenoh matches keys, never QoS",
                                                           "        pass")],
               score=1.5, property="across processes every pair connects", says="rmw_zenoh"),
        Answer("always connects", code='''
def connects(pub_qos, sub_qos, across_processes):
    return True
''', score=1.0, property="DDS's request/offer rules in one process", says="does not connect"),
        Answer("reliability rule reversed", replace=[(
            "if pub_qos.reliability == ReliabilityPolicy.BEST_EFFORT and sub_qos.reliability == ReliabilityPolicy.RELIABLE:",
            "if pub_qos.reliability == ReliabilityPolicy.RELIABLE and sub_qos.reliability == ReliabilityPolicy.BEST_EFFORT:")],
               score=1.0, property="a subscription may not ask for more reliability than offered",
               says="more reliability"),
        Answer("ignores durability", replace=[(
            "if pub_qos.durability == DurabilityPolicy.VOLATILE and sub_qos.durability == DurabilityPolicy.TRANSIENT_LOCAL:",
            "if False:")], score=1.5, property="a subscription may not ask for more durability than offered",
               says="more durability"),
    ])

NODE = Exercise(
    "ch07.child_node", NB,
    right=[Answer("a Node subclass", code='''
def accumulator_node(ctx):
    from robocourse.bus.qos import QoSProfile
    from robocourse.msgs.std_msgs import Int64

    class Accumulator:
        def __init__(self):
            self.node = ctx.create_node("accumulator")
            self.total = 0
            self.out = self.node.create_publisher(Int64, "/sum", QoSProfile(depth=100))
            self.node.create_subscription(Int64, "/numbers", self.add, QoSProfile(depth=100))

        def add(self, msg):
            self.total += msg.data
            self.out.publish(Int64(data=self.total))

    Accumulator()
''')],
    wrong=[
        Answer("another node name", replace=[('ctx.create_node("accumulator")', 'ctx.create_node("summer")')],
               score=2.5, property="the node is named accumulator", says="expected '/accumulator'"),
        Answer("publishes each number", replace=[("sums.publish(std_msgs.Int64(data=running[0]))",
                                                  "sums.publish(std_msgs.Int64(data=msg.data))")],
               score=1.5, property="the running sum, one per number", says="running sums"),
        Answer("publishes on /sums", replace=[('"/sum", 100)', '"/sums", 100)')],
               score=1.0, property="it publishes /sum", says="no publisher of node 'accumulator' on /sum"),
        Answer("subscribes /number", replace=[('"/numbers", on_number', '"/number", on_number')],
               score=1.0, property="it subscribes /numbers", says="no subscription of node 'accumulator' on /numbers"),
    ])

EXERCISES = [ATTACHMENT, KEY, HASH, QOS, NODE]
