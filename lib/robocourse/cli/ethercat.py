"""``robocourse ethercat slaveinfo`` (SOEM's slaveinfo) and ``robocourse ethercat capture``."""

from __future__ import annotations


def register(sub):
    p = sub.add_parser("ethercat", help="the simulated EtherCAT bus: slaveinfo, pcap capture")
    s = p.add_subparsers(dest="ethercat_command", metavar="ACTION")
    i = s.add_parser("slaveinfo", help="scan a bus and print what SOEM's slaveinfo prints")
    i.add_argument("--ifname", help="a network interface with an EtherCAT bus on it (raw socket, "
                   "root); default: the simulated demo bus in-process")
    i.add_argument("--map", action="store_true", help="print the PDO mapping (slaveinfo -map)")
    i.add_argument("--io-pairs", type=int, default=1, help="simulated bus: DI/DO terminal pairs")
    i.add_argument("--drives", type=int, default=1, help="simulated bus: CiA 402 drives")
    i.add_argument("--coe", action="store_true", help="simulated bus: drives with a CoE mailbox")
    i.set_defaults(func=run_slaveinfo)
    c = s.add_parser("capture", help="write a pcap (Wireshark) of a bring-up and N cycles")
    c.add_argument("file", metavar="FILE.pcap")
    c.add_argument("--cycles", type=int, default=100, help="process-data cycles after OP")
    c.add_argument("--io-pairs", type=int, default=1)
    c.add_argument("--drives", type=int, default=1)
    c.add_argument("--coe", action="store_true", help="drives with a CoE mailbox (SDO traffic)")
    c.set_defaults(func=run_capture)
    p.set_defaults(func=lambda args: p.print_help() or 2)


def _check_counts(args) -> None:
    for name in ("io_pairs", "drives", "cycles"):
        v = getattr(args, name, 0)
        if v < 0:
            raise ValueError(f"--{name.replace('_', '-')} must be 0 or more, got {v}")


def run_slaveinfo(args) -> int:
    from robocourse.ethercat import demo_bus
    from robocourse.ethercat.master import Master, MasterError
    from robocourse.ethercat.slaveinfo import slaveinfo_text

    _check_counts(args)
    # SOEM waits 2 ms for a reply (EC_TIMEOUTRET); a raw interface on a busy laptop gets 20
    m = Master(timeout_us=20_000 if args.ifname else 2000)
    try:
        if args.ifname:
            m.open(args.ifname)
            where = args.ifname
        else:
            m.open(demo_bus(args.io_pairs, args.drives, args.coe))
            where = "sim (in-process demo bus)"
        print(slaveinfo_text(m, where, args.map), end="")
    except (OSError, MasterError) as e:  # no such interface, no CAP_NET_RAW, a bus that broke
        raise ValueError(str(e)) from e
    finally:
        m.close()
    return 0


def run_capture(args) -> int:
    from robocourse.ethercat import demo_bus
    from robocourse.ethercat.master import Master
    from robocourse.ethercat.pcap import PcapWriter

    _check_counts(args)
    with PcapWriter(args.file) as w:
        bus = demo_bus(args.io_pairs, args.drives, args.coe, capture=w)
        m = Master()
        m.open(bus)
        m.bring_up()
        short = 0
        for _ in range(args.cycles):
            m.send_processdata()
            short += m.receive_processdata() != m.expected_wkc
    print(f"wrote {w.count} frames ({bus.frames} requests) to {args.file}: bring-up to OP and "
          f"{args.cycles} LRW cycles, expected WKC {m.expected_wkc}, {short} short cycles; "
          f"open it with: wireshark {args.file}  or  tshark -r {args.file}")
    return 0
