"""A plain eclipse-zenoh peer that knows rmw_zenoh's format from the reference only (no
robocourse import): it puts std_msgs/String with the 33-byte attachment, declares tokens
(well-formed, malformed, wrong hash), queries a service and decodes what robocourse sends with
mcap_ros2's CDR codec. Run by tests/test_zenoh_processes.py; prints one JSON line per event."""

import json
import struct
import sys
import time

import zenoh
from mcap_ros2._dynamic import generate_dynamic, serialize_dynamic

STRING_HASH = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
ADD_HASH = "RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a"
GID = bytes(range(100, 116))


def att(seq):
    return struct.pack("<qqB16s", seq, time.time_ns(), 16, GID)


def out(**kw):
    print(json.dumps(kw), flush=True)


def main(role, endpoint):
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("connect/endpoints", f'["{endpoint}"]')
    conf.insert_json5("listen/endpoints", '["tcp/127.0.0.1:0"]')
    conf.insert_json5("scouting/multicast/enabled", "false")
    s = zenoh.open(conf)
    zid = str(s.zid())
    enc = serialize_dynamic("std_msgs/String", "string data\n")["std_msgs/String"]
    dec = generate_dynamic("std_msgs/String", "string data\n")["std_msgs/String"]
    key = f"0/chatter/std_msgs::msg::dds_::String_/{STRING_HASH}"
    keep = []
    if role == "talk":   # a rmw_zenoh-style talker: tokens + puts with attachment
        keep.append(s.liveliness().declare_token(f"@ros2_lv/0/{zid}/0/0/NN/%/%/raw_talker"))
        keep.append(s.liveliness().declare_token(
            f"@ros2_lv/0/{zid}/0/1/MP/%/%/raw_talker/%chatter/std_msgs::msg::dds_::String_/"
            f"{STRING_HASH}/::,7:,:,:,,"))

        def heard(sample):
            a = sample.attachment.to_bytes()
            seq, _ts, n, gid = struct.unpack("<qqB16s", a)
            out(heard=dec(sample.payload.to_bytes()).data, seq=seq, gidlen=n, attlen=len(a),
                head=sample.payload.to_bytes()[:4].hex())
        keep.append(s.declare_subscriber(f"0/heard/std_msgs::msg::dds_::String_/{STRING_HASH}",
                                         heard))
        out(ready=zid)
        for i in range(1, 400):
            s.put(key, enc({"data": f"raw {i}"}), attachment=att(i))
            time.sleep(0.01)
    elif role == "faults":
        keep.append(s.liveliness().declare_token(f"@ros2_lv/0/{zid}/0/0/XX/%/%/bad_kind"))
        keep.append(s.liveliness().declare_token(
            f"@ros2_lv/0/{zid}/0/1/MP/%/%/old_talker/%chatter/std_msgs::msg::dds_::String_/"
            f"RIHS01_{'0' * 64}/::,7:,:,:,,"))
        out(ready=zid)
        for i in range(1, 400):
            s.put(key, enc({"data": f"no attachment {i}"}))                   # dropped
            s.put(f"0/chatter/std_msgs::msg::dds_::String_/RIHS01_{'0' * 64}",
                  enc({"data": f"other hash {i}"}), attachment=att(i))       # other key
            s.put(key, b"\x00\x01\x00\x00\xff\xff\xff\x7fabc", attachment=att(i))  # huge length
            s.put(key, b"not CDR at all", attachment=att(i))                # no CDR header
            time.sleep(0.01)
    elif role == "call":
        req = serialize_dynamic("example_interfaces/AddTwoIntsRequest", "int64 a\nint64 b\n")[
            "example_interfaces/AddTwoIntsRequest"]
        rdec = generate_dynamic("example_interfaces/AddTwoIntsResponse", "int64 sum\n")[
            "example_interfaces/AddTwoIntsResponse"]
        skey = f"0/add_two_ints/example_interfaces::srv::dds_::AddTwoInts_/{ADD_HASH}"
        out(ready=zid)
        while not any(r.ok for r in s.liveliness().get("@ros2_lv/0/**/SS/**", timeout=1.0)):
            time.sleep(0.05)      # wait_for_service: the server's token (queryable declared first)
        for r in s.get(skey, payload=b"\x00\x01\x00\x00\x02", attachment=att(40),
                       target=zenoh.QueryTarget.ALL_COMPLETE,
                       consolidation=zenoh.ConsolidationMode.NONE, timeout=10.0):
            out(truncated_request_error=None if r.ok is not None else
                str(r.err.payload.to_string()))          # 1 of AddTwoInts' 16 bytes
        for seq in (41, 42):
            for r in s.get(skey, payload=req({"a": seq, "b": 1}), attachment=att(seq),
                           target=zenoh.QueryTarget.ALL_COMPLETE,
                           consolidation=zenoh.ConsolidationMode.NONE, timeout=10.0):
                if r.ok is None:        # an error reply: say so, the test shows it
                    out(error=str(r.err.payload.to_string()), seq=seq)
                    continue
                a = r.ok.attachment.to_bytes()
                rseq, _ts, _n, gid = struct.unpack("<qqB16s", a)
                out(sum=rdec(r.ok.payload.to_bytes()).sum, seq=rseq, gid_echoed=gid == GID,
                    key=str(r.ok.key_expr))
    sys.stdin.read()     # until the test closes our stdin
    s.close()


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
