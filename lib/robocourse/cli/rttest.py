"""``robocourse rttest [rttest options]`` and ``robocourse rttest-plot FILE`` (rttest, rttest_plot).

``rttest`` runs an instrumented empty loop the way a program linked against rttest does:
lock memory and prefault (-m stack, -d heap), set the policy and priority (-s, -t), spin
-i iterations at period -u, print rttest's statistics block, write -f. Missing privileges
print the seed's messages with the fix, and the run carries on. It sleeps to each deadline as
rttest does; ``--wait hybrid`` (sleep, then spin the last ``--spin``), ``--wait adaptive`` (spin
only the window this machine's sleeps need, learned as it runs, at most ``--spin``) or
``--wait spin`` must be asked for, and the statistics block names the strategy that ran.
"""

from __future__ import annotations

import argparse
import sys


def register(sub):
    p = sub.add_parser(
        "rttest", help="measure a periodic loop like rttest: -i N -u 1ms -s fifo -t 98 -f FILE",
        description="Run an instrumented empty loop and print rttest's statistics. Options as rttest: "
                    "-i ITERATIONS (<=0: until Ctrl-C), -u PERIOD (ns/us/ms/s, bare = us), -t PRIORITY, "
                    "-s fifo|rr, -m STACK and -d HEAP prefault sizes (gb/mb/kb/b, bare = MB), -f FILE; "
                    "robocourse adds --wait sleep|hybrid|adaptive|spin (default sleep, as rttest), --spin DURATION, --cpu N.",
        prefix_chars="+", add_help=False)
    p.add_argument("rttest_args", nargs=argparse.REMAINDER)
    p.set_defaults(func=run_rttest)

    q = sub.add_parser("rttest-plot", help="draw rttest_plot's four figures from a results file")
    q.add_argument("file", help="results file written by rttest or robocourse rttest -f")
    q.add_argument("--prefix", help="output prefix (default FILE_plot)")
    q.add_argument("--format", default="svg", choices=["svg", "png"], help="image format (default svg)")
    q.set_defaults(func=run_plot)


DEFAULT_HEAP = 64 * 1024 * 1024


def _heap_cap(requested: int) -> tuple[int, str]:
    """rttest's default heap prefault cap is 8 GiB; never take more than a quarter of free RAM."""
    try:
        with open("/proc/meminfo") as fh:
            avail = next(int(line.split()[1]) * 1024 for line in fh if line.startswith("MemAvailable:"))
    except (OSError, StopIteration, ValueError):
        return requested, ""
    cap = avail // 4
    if requested > cap:
        return cap, (f"heap prefault capped at {cap >> 20} MiB (a quarter of MemAvailable) "
                     f"instead of the requested {requested >> 20} MiB")
    return requested, ""


def run_rttest(args) -> int:
    from robocourse.rt import settings
    from robocourse.rt.loop import PeriodicLoop, _faults
    from robocourse.rt.options import RttestUsageError, parse_rttest_args
    from robocourse.rt.wait import strategy

    argv = list(args.rttest_args)
    if any(a in ("-h", "--help") for a in argv):
        from robocourse.rt.options import help_text

        print(help_text("robocourse rttest"))
        return 0
    try:
        opts = parse_rttest_args(argv)
    except RttestUsageError as exc:
        print(f"robocourse rttest: error: {exc}", file=sys.stderr)
        return 2
    if opts.cpu is not None:
        print(settings.set_affinity(opts.cpu))
    explicit_cap = any(a.startswith("-d") for a in argv)
    if explicit_cap:
        heap, note = _heap_cap(opts.heap_size)
    else:
        heap, note = min(opts.heap_size, DEFAULT_HEAP), ""
    if note:
        print(note)
    for r in settings.lock_and_prefault(opts.stack_size, heap, until_no_faults=True):
        print(r)
        if r.name == "heap prefault" and not explicit_cap:
            # one statement about the heap: what happened is the line above; this only names the cap
            print(f"{'':20}cap: robocourse's default, {DEFAULT_HEAP >> 20} MiB (rttest's default cap is 8 GiB: "
                  "pass -d 8gb for rttest's)")
    print(settings.gc_freeze())
    print(settings.set_scheduling(opts.policy, opts.priority))
    minflt, majflt = _faults()
    print(f"Initial major pagefaults: {majflt}")
    print(f"Initial minor pagefaults: {minflt}")
    wait = strategy(opts.wait, opts.spin_ns)
    loop = PeriodicLoop(opts.period_ns, opts.iterations, wait=wait)
    result = loop.run()
    settings.reset_scheduling()
    settings.unlock_memory()
    print()
    print(result.stats().format(name=opts.filename))
    if hasattr(wait, "window_ns"):
        print(wait.describe(opts.period_ns))   # what the adaptive wait learned, and its cost
    if opts.filename:
        if opts.iterations <= 0:
            print("No sample buffer was saved, not writing results", file=sys.stderr)
        else:
            result.write(opts.filename)
            print(f"wrote {opts.filename} (plot it with: robocourse rttest-plot {opts.filename})")
    return 0


def run_plot(args) -> int:
    import matplotlib

    matplotlib.use("Agg")
    from robocourse.rt.plot import rttest_plot

    for path in rttest_plot(args.file, prefix=args.prefix, fmt=args.format):
        print(f"wrote {path}")
    return 0
