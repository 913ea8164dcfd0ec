"""Chapter 1's answer bank: plausible wrong answers (one per stated property) and correct ones.

The worked example of robocourse.grading.bank: every answer below runs in the student's place
in the grading sandbox; the reference is the solution notebook's cell.
"""

from robocourse.grading.bank import Answer, Exercise

NB = "01_realtime_exercises"

STATS = Exercise(
    "ch01.rttest_stats", NB,
    right=[Answer("plain python, no numpy", code='''
def rttest_statistics(latency_ns, minor_pagefaults, major_pagefaults):
    values = [int(x) for x in latency_ns]
    n = len(values)
    mean = sum(values) / n
    variance = sum((v - mean) ** 2 for v in values) / n
    return {"min_latency": min(values), "max_latency": max(values), "mean_latency": mean,
            "latency_stddev": variance ** 0.5, "minor_pagefaults": int(sum(minor_pagefaults)),
            "major_pagefaults": int(sum(major_pagefaults))}
''')],
    wrong=[
        Answer("min and max as floats", replace=[("int(lat.min())", "float(lat.min())"),
                                                 ("int(lat.max())", "float(lat.max())")],
               score={"the mean over all samples": 0.5, "the population standard deviation (divide by n)": 0.5,
                      "the total page faults (sum of the deltas)": 0.5},
               property="min and max as ints", says="rttest reports it as an int"),
        Answer("min of the absolute latencies", replace=[("int(lat.min())", "int(np.abs(lat).min())")],
               score=1.5, property="min over every sample, negative ones too", says="negative ones too"),
        Answer("an integer mean", replace=[('"mean_latency": float(mean)', '"mean_latency": int(lat.sum() // lat.size)')],
               score=1.5, property="the mean over all samples, as a float", says="mean_latency is"),
        Answer("sample standard deviation", replace=[("np.mean((lat - mean) ** 2)",
                                                      "np.sum((lat - mean) ** 2) / max(lat.size - 1, 1)")],
               score=1.5, property="the population standard deviation", says="*sample* standard deviation"),
        Answer("counts iterations with a fault", replace=[("int(np.sum(minor_pagefaults))",
                                                           "int(np.count_nonzero(minor_pagefaults))"),
                                                          ("int(np.sum(major_pagefaults))",
                                                           "int(np.count_nonzero(major_pagefaults))")],
               score=1.5, property="the total page faults", says="rttest sums them"),
        Answer("a misspelled key", replace=[('"latency_stddev":', '"latency_std":')], score=1.5,
               property="the six rttest keys", says="lacks latency_stddev"),
        Answer("calls the library's compute_stats", code='''
from robocourse.rt.stats import compute_stats

def rttest_statistics(latency_ns, minor_pagefaults, major_pagefaults):
    s = compute_stats(latency_ns, minor_pagefaults, major_pagefaults)
    return {k: getattr(s, k) for k in ("min_latency", "max_latency", "mean_latency", "latency_stddev",
                                       "minor_pagefaults", "major_pagefaults")}
''', property="written by the student", says="write it yourself"),
    ])

LOOP = Exercise(
    "ch01.drift_free_loop", NB,
    right=[Answer("a while loop adding the period", code='''
def absolute_loop(clock, period_ns, iterations, callback):
    out = []
    deadline = clock.now_ns()
    k = 0
    while k < iterations:
        deadline += period_ns
        clock.sleep_until_ns(deadline)
        woke = clock.now_ns()
        out.append(woke - deadline)
        callback(k)
        k += 1
    return np.array(out)
''')],
    wrong=[
        Answer("relative sleeps", code='''
def absolute_loop(clock, period_ns, iterations, callback):
    latencies = []
    for k in range(iterations):
        before = clock.now_ns()
        clock.sleep_ns(period_ns)
        latencies.append(clock.now_ns() - before - period_ns)
        callback(k)
    return latencies
''', score={"calls callback(k) once per iteration, after waking": 0.5}, property="absolute deadlines",
               says="relative sleep"),
        Answer("next deadline from now", code='''
def absolute_loop(clock, period_ns, iterations, callback):
    latencies = []
    for k in range(iterations):
        deadline = clock.now_ns() + period_ns
        clock.sleep_until_ns(deadline)
        latencies.append(clock.now_ns() - deadline)
        callback(k)
    return latencies
''', score=1.5, property="deadlines do not move after a late iteration", says="must not move"),
        Answer("off by one period", replace=[("(k + 1) * period_ns", "k * period_ns")], score=1.5,
               property="deadline_k = start + (k + 1) * period", says="off by one period"),
        Answer("latency read after the callback", replace=[(
            "        latencies.append(clock.now_ns() - deadline)\n        callback(k)",
            "        callback(k)\n        latencies.append(clock.now_ns() - deadline)")], score=2.0,
               property="the latency is read right after waking, before the callback",
               says="*before* the callback"),
        Answer("callback before the sleep", replace=[(
            "        clock.sleep_until_ns(deadline)\n        latencies.append(clock.now_ns() - deadline)\n"
            "        callback(k)",
            "        callback(k)\n        clock.sleep_until_ns(deadline)\n"
            "        latencies.append(clock.now_ns() - deadline)")], score=2.5,
               property="the callback runs after waking", says="before its deadline",
               never_says="latency of iteration"),
        Answer("callback without k", replace=[("callback(k)", "callback()")], score=2.5,
               property="callback(k) gets the iteration number", says="with the iteration number"),
        Answer("forgets to return", replace=[("    return latencies", "    pass")], score=2.0,
               property="returns the latencies", says="return the latencies"),
        Answer("runs the library's PeriodicLoop", code='''
import robocourse.rt as rt

def absolute_loop(clock, period_ns, iterations, callback):
    run = rt.PeriodicLoop(period_ns, iterations, clock=clock, pagefaults=False).run(lambda tick: callback(tick.iteration))
    return list(run.latency_ns)
''', property="written by the student", says="write it yourself"),
    ])

DRIFT = Exercise(
    "ch01.relative_drift", NB,
    right=[Answer("enumerate from 1", code='''
def drift_ns(wake_ns, start_ns, period_ns):
    return np.array([w - (start_ns + k * period_ns) for k, w in enumerate(wake_ns, start=1)])
''')],
    wrong=[
        Answer("off by one period", replace=[("+ 1) * period_ns", ") * period_ns")], score=0.25,
               property="wake-up k belongs to start + (k + 1) * period", says="off by one period"),
        Answer("period-to-period increments", code='''
def drift_ns(wake_ns, start_ns, period_ns):
    return np.diff(np.concatenate([[start_ns], np.asarray(wake_ns)])) - period_ns
''', score=0.25, property="drift from the absolute deadline, not from the previous wake-up", says="expected"),
        Answer("deadline minus wake", replace=[("return wake - (start_ns + (np.arange(len(wake), dtype=np.int64) + 1) "
                                                "* period_ns)",
                                                "return (start_ns + (np.arange(len(wake), dtype=np.int64) + 1) "
                                                "* period_ns) - wake")],
               score=0.25, property="drift = wake - deadline (late is positive)", says="expected"),
        Answer("32-bit integers", replace=[("dtype=np.int64)\n", "dtype=np.int32)\n")], score=0.25,
               property="ns timestamps need 64 bits", says="expected"),
        Answer("a list, not an array", code='''
def drift_ns(wake_ns, start_ns, period_ns):
    return [int(w) - (start_ns + (k + 1) * period_ns) for k, w in enumerate(wake_ns)]
''', score=0.75, property="returned as a numpy array", says="numpy array"),
    ])

BUDGET = Exercise(
    "ch01.budget", NB,
    right=[Answer("quantile and all()", code='''
def controller_budget_ns(period_ns, latency_ns, percentile=99.9):
    tail = float(np.quantile(np.asarray(latency_ns, dtype=float), percentile / 100))
    return period_ns - tail if tail < period_ns else 0


def meets_5_percent(latency_ns, period_ns):
    return all(x <= period_ns / 20 for x in latency_ns)
''')],
    wrong=[
        Answer("mean latency", replace=[("float(np.percentile(latency_ns, percentile))", "float(np.mean(latency_ns))")],
               score=1.25, property="the budget is after the tail percentile", says="*mean* latency"),
        Answer("maximum latency", replace=[("float(np.percentile(latency_ns, percentile))", "float(np.max(latency_ns))")],
               score=1.25, property="the budget is after the given percentile", says="*maximum* latency"),
        Answer("percentile as a fraction", replace=[("np.percentile(latency_ns, percentile)",
                                                     "np.percentile(latency_ns, percentile / 100)")],
               score=1.25, property="percentile in percent, as np.percentile takes it", says="expected"),
        Answer("negative budgets", replace=[("return max(0.0, period_ns - float(np.percentile(latency_ns, percentile)))",
                                             "return period_ns - float(np.percentile(latency_ns, percentile))")],
               score=1.5, property="never negative", says="return 0"),
        Answer("strict comparison", replace=[("<= 0.05 * period_ns", "< 0.05 * period_ns")], score=1.25,
               property="at most 5 % (inclusive)", says="inclusive"),
        Answer("rule on the mean", replace=[("np.max(latency_ns) <=", "np.mean(latency_ns) <=")], score=1.25,
               property="the rule is judged on the maximum", says="not the mean"),
    ])

KNOB = Exercise(
    "ch01.which_knob", NB,
    right=[Answer("the other right knob for timer slack, by index", code='''
from robocourse.rt.probes import KNOBS, TAILS


def which_knob():
    return dict(zip(TAILS, [KNOBS[2], KNOBS[1], KNOBS[2], KNOBS[3]]))
''')],
    wrong=[
        Answer("more iterations for gc pauses", replace=[('"gc pause": "gc.freeze()"', '"gc pause": "more iterations"')],
               score=0.75, property="gc pause -> gc.freeze()", says="gc.freeze() moves"),
        Answer("hybrid wait for other processes", replace=[('"other processes on the same core": "SCHED_FIFO priority"',
                                                            '"other processes on the same core": "hybrid wait"')],
               score=0.75, property="other processes -> SCHED_FIFO", says="preempts every SCHED_OTHER task"),
        Answer("swaps page faults and gc", replace=[('"page faults in the loop": "mlockall + prefault"',
                                                     '"page faults in the loop": "gc.freeze()"'),
                                                    ('"gc pause": "gc.freeze()"', '"gc pause": "mlockall + prefault"')],
               score=0.5, property="page faults -> mlockall + prefault", says="first touches of memory fault"),
        Answer("a knob that is not on the list", replace=[('"gc pause": "gc.freeze()"', '"gc pause": "gc.freeze"')],
               score=0.75, property="answers from KNOBS", says="is not one of the knobs"),
        Answer("SCHED_FIFO for everything", code='''
def which_knob():
    return {tail: "SCHED_FIFO priority" for tail in ("timer slack oversleep", "page faults in the loop",
                                                     "other processes on the same core", "gc pause")}
''', score=0.5, property="one knob per cause", says="does not remove it"),
    ])

EXERCISES = [STATS, LOOP, DRIFT, BUDGET, KNOB]
