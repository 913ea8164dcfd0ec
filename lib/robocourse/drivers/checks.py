"""Checks for chapter 5's driver exercise (solutions/05_hardware_drivers_exercises.ipynb), as probe + judge.

``ch05.franka_link``: the student's ``read()``/``write()`` (the cyclic pair of a Franka-style
SystemInterface, franka_hardware's readOnce/writeOnce) run against a real Franka-style box
process over loopback UDP, through a scripted load test: first chapter 1's CPU load
(:class:`robocourse.rt.disturb.CpuLoad`, busy processes competing for a core) for the first
``LOAD_TICKS`` ticks, then ``PAUSES`` pauses of ``PAUSE_MS`` ms between read() and write() at random ticks (a gc
pause, heavy computation in the loop). The probe returns what
the box counted (missed and late ticks, reflexes, malformed commands) and what the student's
read() reported; the judge decides. A loop that answers queued stale states one by one after
a pause sends a late command for every one of them; one that keeps only the newest state
loses one command per pause. Finally the probe stalls past ``max_missed`` on purpose: the
box's communication_constraints_violation reflex must show in the student's ``errors``.
"""

from __future__ import annotations

import math

from robocourse.grading import CheckFailed, Failures, register
from robocourse.grading.probes import number

TICKS = 2000
RAMP = 300
LOAD_TICKS = 500       # ticks run under CpuLoad (the pauses come after)
PAUSES = 4             # pauses between read() and write() after the load phase
PAUSE_MS = (8, 14)     # each lasts a whole number of ms in this range
LOAD_PROCESSES = 1    # one busy process: with two, a 2-core machine already loaded failed the solution 3 of 5 times
MAX_MISSED = 80    # ms: generous, so a loaded grading machine does not trip it; the stall test goes past it
OFFSET = (0.15, -0.1, 0.1, 0.0, 0.1, -0.1)   # rad, reached after RAMP ticks


def _inputs(rng):
    ticks = sorted(int(t) for t in rng.choice(range(max(RAMP, LOAD_TICKS) + 50, TICKS - 50), size=PAUSES, replace=False))
    return {"ticks": TICKS, "load": [LOAD_TICKS, LOAD_PROCESSES],
            "pauses": [[t, int(rng.integers(PAUSE_MS[0], PAUSE_MS[1] + 1))] for t in ticks], "max_missed": MAX_MISSED,
            "offset": list(OFFSET)}


def _box_stats(port: int) -> dict:
    """The box's counters, asked from a socket of our own (the box answers STATS to anyone); {} if silent."""
    from .franka_client import NetworkException, query_box_stats

    try:
        return query_box_stats(port=port, timeout=2.0)
    except NetworkException:
        return {}


def _attr(obj, name):
    from robocourse.grading.probes import plain

    try:
        return plain(getattr(obj, name))
    except Exception as exc:
        return {"type": "missing", "repr": f"{type(exc).__name__}: {exc}"[:200]}


def _probe(inputs, FrankaLink):  # noqa: N803 (the notebook's class name)
    """Run the student's read()/write() for ``ticks`` states against a Franka-style box process."""
    import contextlib
    import time

    import numpy as np

    from robocourse.rt.disturb import CpuLoad

    from . import start_franka_box

    out = {"error": None, "seqs": [], "read_timeouts": 0, "box_seq_after_pause": []}
    pauses = dict(inputs["pauses"])
    offset = np.asarray(inputs["offset"], dtype=float)
    box = start_franka_box(max_missed=inputs["max_missed"])
    link = None
    load_ticks, load_processes = inputs["load"]
    load = contextlib.ExitStack()
    try:
        load.enter_context(CpuLoad(processes=load_processes))   # spinning before the loop starts
        port = box.ports["udp"]
        try:
            link = FrankaLink(port)
            if not link.read(1.0):
                out["error"] = "the first read() found no state within 1 s"
                return out
            q0 = np.array(link.q, dtype=float)
            out["q0"] = q0.tolist()
            k = 0
            while k < inputs["ticks"]:
                if not link.read(0.1):
                    out["read_timeouts"] += 1
                    if out["read_timeouts"] > 20:
                        break
                    continue
                out["seqs"].append(_attr(link, "seq"))
                if k == load_ticks:
                    load.close()
                    out["stats_after_load"] = _box_stats(port)
                if k in pauses:
                    time.sleep(pauses[k] / 1000)      # the disturbance, between read() and write()
                    # the newest state the box has sent by now (asked on our own socket): it is
                    # already queued on the student's socket, so their next read() must reach it
                    out["box_seq_after_pause"].append([k, _box_stats(port).get("seq")])
                link.write(q0 + min(1.0, k / RAMP) * offset)
                k += 1
            out["q_final"] = _attr(link, "q")
            out["errors_before"] = _attr(link, "errors")
            out["stats"] = _box_stats(port)
            # stall on purpose, past max_missed: the box must brake, and read() must say so
            # (polled: on a loaded machine the box may skip ticks, so a fixed sleep could fall short)
            time.sleep((inputs["max_missed"] + 20) / 1000)
            for _ in range(40):
                if _box_stats(port).get("reflexes") or not out["stats"].get("commands_ok"):
                    break
                time.sleep(0.05)
            fresh = link.read(0.5)
            out["read_after_stall"] = bool(fresh)
            out["errors_after_stall"] = _attr(link, "errors")
            out["stats_after_stall"] = _box_stats(port)
        except NotImplementedError:
            raise
        except Exception as exc:
            out["error"] = f"{type(exc).__name__}: {str(exc)[:300]}"
    finally:
        load.close()
        if link is not None:
            try:
                link.close()
            except Exception:
                pass
        box.stop()
    return out


def _count(stats, key) -> int:
    v = stats.get(key, 0) if isinstance(stats, dict) else 0
    return int(v) if isinstance(v, int) and not isinstance(v, bool) else 0


@register("ch05.franka_link", weight=3, time_limit=60, uses=("FrankaLink",), probe=_probe, inputs=_inputs,
          references=("robocourse.drivers.franka_client:Robot",), timing=True)
def check_franka_link(inputs, out):
    """FrankaLink.read()/write() keep a Franka-style box moving through pauses, and see its reflex."""
    if not isinstance(out, dict):
        raise CheckFailed(f"the probe returned {str(out)[:80]}")
    if out.get("error"):
        raise CheckFailed(f"the loop stopped: {out['error']}")
    f = Failures()
    stats = out.get("stats") or {}
    if not stats:
        raise RuntimeError("check error: the box did not answer the STATS request")
    n_pauses = len(inputs["pauses"])
    ticks = inputs["ticks"]
    pause_ms = sum(p for _, p in inputs["pauses"])
    late, missed = _count(stats, "late"), _count(stats, "missed")
    moving, ok = _count(stats, "ticks_moving"), _count(stats, "commands_ok")
    if _count(stats, "reflexes"):
        f.add(f"the box stopped with communication_constraints_violation during the run ({missed} ticks missed, at "
              f"most {_count(stats, 'max_missed_in_row')} in a row; the limit is {inputs['max_missed']})")
    for key, why in (("rx_bad_seq", "a command must carry the seq of the state it answers, never a later one"),
                     ("rx_bad_length", "a COMMAND is the 16-byte header + command_struct(n) (n = 6 joints)"),
                     ("rx_bad_mode", "mode must be 1 (position)"),
                     ("rx_bad_magic", "every datagram starts with b'RCFR'"),
                     ("rx_bad_version", "the protocol version is 1"),
                     ("duplicates", "answer each state once: write() twice for one read() is a duplicate")):
        if _count(stats, key):
            f.add(f"the box counted {_count(stats, key)} × {key}: {why}")
    allowed_late = 2 * n_pauses + ticks // 40     # load on the grading machine adds some
    if late > allowed_late:
        f.add(f"{late} commands arrived late (after the next tick) for {n_pauses} pauses of {pause_ms} ms in all; "
              f"at most {allowed_late} allowed. After a pause the socket holds every state sent meanwhile: read() "
              "must drain it and keep only the newest, or each stale state gets a late answer")
    if moving and ok < 0.8 * moving:
        f.add(f"only {ok} of {moving} ticks got a command in time ({ok / moving:.1%}); the pauses alone cost about "
              f"{pause_ms + n_pauses} ticks")
    seqs = out.get("seqs") or []
    ints = [s for s in seqs if isinstance(s, int) and not isinstance(s, bool)]
    if len(ints) != len(seqs):
        f.add(f"after read(), .seq must be the state's sequence number (an int); got {str(seqs[:3])[:60]}")
    elif any(b <= a for a, b in zip(ints, ints[1:])):
        k = next(i for i, (a, b) in enumerate(zip(ints, ints[1:])) if b <= a)
        f.add(f"read() returned True twice for the same or an older state (seq {ints[k]} then {ints[k + 1]}): "
              "it must report only states newer than the last one answered")
    else:
        # the decisive test: the first read() after a pause must reach the newest state the box
        # had sent by the pause's end (measured, so the machine's load cannot fool it), not the
        # next one queued (seq + 1)
        pause_ms_at = dict(inputs["pauses"])
        for rec in out.get("box_seq_after_pause") or []:
            k, newest = rec if isinstance(rec, list) and len(rec) == 2 else (None, None)
            if not isinstance(k, int) or not isinstance(newest, int) or k + 1 >= len(ints):
                continue
            if newest - ints[k] >= 2 and ints[k + 1] < newest:
                f.add(f"after a {pause_ms_at.get(k, '?')} ms pause at tick {k} (state {ints[k]}), the box had sent up "
                      f"to state {newest}, but read() returned {ints[k + 1]}: drain the socket and keep the newest "
                      "(franka_hardware answers the latest state, never a stale one)")
    if out.get("read_timeouts"):
        f.add(f"read() found no new state {out['read_timeouts']} times while the box was sending one every ms")
    q0, qf = out.get("q0"), out.get("q_final")
    try:
        target = [number(a) + b for a, b in zip(q0, inputs["offset"], strict=True)]
        err = max(abs(number(a) - b) for a, b in zip(qf, target, strict=True))
        if not math.isfinite(err) or err > 0.02:
            f.add(f".q after the run is {[round(number(x), 3) for x in qf]}, the commanded target "
                  f"{[round(x, 3) for x in target]} (error {err:.3f} rad): .q must be the measured joint "
                  "positions, the first n floats after the header")
    except (TypeError, ValueError):
        f.add(f".q must be the 6 joint positions; got {str(qf)[:80]} (first read {str(q0)[:80]})")
    after = out.get("stats_after_stall") or {}
    if ok == 0:
        f.add("the box never accepted a command, so the arm never moved: each COMMAND must carry the seq of the "
              "newest STATE read() kept, with the 16-byte header and command_struct(n)")
    elif _count(after, "reflexes") >= 1:
        e = out.get("errors_after_stall")
        if not (isinstance(e, int) and not isinstance(e, bool) and e & 1):
            f.add(f"after a stall of more than {inputs['max_missed']} ms the box braked (communication_constraints_"
                  f"violation), but .errors after read() is {str(e)[:40]}: decode the state's errors field (bit 0)")
    else:
        raise RuntimeError("check error: the deliberate stall did not trigger the box's reflex")
    under = out.get("stats_after_load") or {}
    load_txt = (f"{_count(under, 'commands_ok')}/{_count(under, 'ticks_moving')} on time under CPU load, "
                if _count(under, "ticks_moving") else "")
    return f.done(f"{load_txt}{ticks} states answered through CPU load and {n_pauses} pauses ({pause_ms} ms): "
                  f"{late} late, {missed} missed, "
                  f"{ok}/{moving} on time, no reflex; the deliberate stall's reflex seen in .errors")
