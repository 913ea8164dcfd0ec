"""Chapter markdown holds no measured figure and no verdict about a measurement (issue 25).

A measured number or verdict is printed by a code cell from the measurement
(``robocourse.notebook.claim``); markdown holds definitions, settings and labelled quotes. The
rule and its allowed forms are in ``robocourse.notebook.markdown_rules``; in short, in markdown:

- a value the code sets, or a definition: write it as code or math (``a `1 kHz` loop``,
  ``$L = 0.5$ m``) or as an assignment (``dt = 1 ms``);
- a figure from elsewhere: label it with its source, ``(source: ROS 2 docs, ...)`` or
  ``quoted from ...``;
- anything measured on the student's machine: a code cell renders it (``claim(...)``).

KNOWN VIOLATIONS, READ THIS BEFORE EDITING THE LIST BELOW. ``KNOWN_VIOLATIONS`` lists, per
notebook, the exact sentences (as ``markdown_rules.sentences`` splits them, whitespace collapsed)
that broke the rule when the rule was introduced. The list may only SHRINK: when you fix a
sentence (rewrite it, render it from the data, mark a setting as code, label a quote), delete
its entry; the test fails on an entry that no longer breaks the rule, so a stale entry cannot
linger. Never add an entry to make a new sentence pass: fix the sentence.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from robocourse.notebook.markdown_rules import (
    check_markdown,
    check_sentence,
    notebook_violations,
    sentences,
)

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted(p.relative_to(ROOT).as_posix() for p in
                   [*ROOT.glob("chapters/*.ipynb"), *ROOT.glob("solutions/*.ipynb")])

KNOWN_VIOLATIONS: dict[str, list[str]] = {
    'chapters/00_setup_check.ipynb': [
        "- **kernel preemption**: only a `PREEMPT_RT` kernel bounds worst-case latency to tens of microseconds; on a stock kernel the ROS docs report maxima of milliseconds (2.75 ms in their run; chapter 1 measures this machine's).",
        'Ask for 1 ms, a few hundred times, and measure how late each wake-up is.',
    ],
    'chapters/01_realtime_basics.ipynb': [
        "The ROS 2 real-time demo runs an inverted pendulum's controller in a **1 kHz loop** and asks one question of it: *does every iteration start on time?* It answers with **rttest**: after each deadline it records how late the thread woke up (the *latency*) and how many page faults the iteration took, and prints a statistics block.",
        'The target: the **maximum** latency stays under **5 % of the period**, 50 µs at 1 kHz.',
        'rttest_plot draws the histogram on 100 *linear* bins: with a 10 µs median and a millisecond worst case, the whole distribution is one or two bars and the tail is a few invisible ones.',
        "A loop can *sleep* to its deadline (rttest's way: cheap, late by the timer slack and wake-up latency), *spin* (read the clock in a tight loop: punctual, and it burns all the CPU time it gets) or do both: **hybrid** sleeps until a spin window before the deadline, then spins.",
        "Under `SCHED_FIFO` a spinning thread is never preempted by normal tasks but runs into **RT throttling**: the kernel reserves `sched_rt_runtime_us` of every `sched_rt_period_us` for real-time tasks (950 ms of each second by default; the report at the top shows this machine's values) and takes the CPU away from them for the rest, a stall of tens of milliseconds.",
        "**allocate in the loop** with glibc's defaults (`HeapGrowth`: a new 64 KiB buffer every iteration, 200 kept alive, then all dropped);",
        "The limit `RLIMIT_MEMLOCK` (`ulimit -l`, in kB) must cover the *whole* process, and the machine must have that much RAM free for as long as the program runs (the seed's rttest prefaults up to 8 GiB of heap by default; robocourse caps it at 64 MiB unless you pass `-d`).",
        'The loop (`SCHED_FIFO` 80) reads a value that a low-priority process (`SCHED_FIFO` 10) updates under a mutex, holding it 2 ms at a time.',
        'A medium-priority process (`SCHED_FIFO` 50) that shares nothing with either spins in 20 ms bursts.',
        "The seed's rule (max <= 5 % of the period) is judged on the worst iteration.",
        "The table is printed from this notebook's medians; the last column says whether the knob helped *here* (in at least 80 % of the rounds).",
    ],
    'chapters/02_pendulum_pid.ipynb': [
        "The seed is ROS 2's `pendulum_control` demo: a motor node simulates an inverted pendulum and a controller node runs a PID on it, both spun by an executor inside rttest's 1 kHz loop.",
        "**The seed's pendulum** (`pendulum_control`, 0.01 kg at 0.5 m).",
        '`pendulum_motor` publishes the angle on `pendulum_sensor` every **970 us** and obeys `pendulum_command`; `pendulum_controller` runs the PID on every sensor message, publishes a command every **960 us**, publishes `pendulum_statistics` every **1 ms** and listens to `pendulum_setpoint`.',
        'Both timers run slightly faster than the 1 ms executor loop so that every iteration has fresh data.',
        'Below, a sensor publishes a stamped angle every 1 ms over a link that loses 5 % of samples and delays each by 0.5 ms; one controller has a BEST_EFFORT and a RELIABLE KEEP_LAST 1 subscription and, every 1 ms, records how old the newest angle it holds is.',
        "How long a resend takes is set by the middleware's heartbeat/NACK configuration; here it is a parameter, tried at 1 ms and 10 ms, three seeds each.",
        'Like rttest it **sleeps** to each deadline; `wait=Hybrid(...)` (or `--wait hybrid` on the command line) sleeps and then spins the last 200 us.',
        'With `use_sim_time`, physics becomes a 1 ms timer on the motor node and the graph is spun for seconds of simulated time in a fraction of that.',
        'Feed both a constant error of 0.1 rad at dt = 1 ms:',
        "The newer ROS 2 real-time demo balances a cart-pole (pole 1 kg at 2 m, cart 5 kg, damping 20, force limit 1000 N, ±1 noise on the pole's acceleration) with full-state feedback `u = -K (x - ref)`, **K = [-10.0000, -51.5393, 356.8637, 154.4146]** (the demo's values).",
        'What the difference between the two gains does to the closed loop, in the nonlinear simulation from a 0.2 rad offset (noise on, seeded):',
        "**Design.** Every trial starts *settled* (upright, at rest), with the demo's ±1 rad/s² noise on the pole's acceleration drawn from the trial's own seed, and runs 1.3 s at 1 kHz; a trial *falls* when the pole leaves 0.5 rad of upright.",
        'Many trials per condition, each with a different seed (and a different window of a measured trace, or a different moment for a synthetic stall), give a fall probability with a 95 % Wilson interval.',
        'The view is framed from the recording itself: the camera looks across the plane the pole swings in, so the rail runs left to right, and steps back until every recorded pose fits in 80 % of the view; the grid squares and the black bar on the floor give the scale (both sizes are printed under the scene and written on the label).',
        "And model 2, the seed's pendulum (0.01 kg at 0.5 m) driven by torque, as a MuJoCo model, caught from $\\delta$ = -0.3 rad (MuJoCo's hinge $q$ = 0.3) by the PD torque controller of the root-locus section (kp = 0.1 > m g L = 0.049, kd = 0.02):",
    ],
    'chapters/04_ros2_control.ipynb': [
        "`cm.run_realtime(seconds)` runs ros2_control_node's loop on the wall clock: absolute deadlines at the manager's `update_rate`, each stage timed (`read` = MuJoCo state -> state interfaces; `update` = the two active controllers; `write` = commands -> MuJoCo, which also steps the physics 2 ms).",
        'If `on_activate` does not copy the measured positions into the commands, the first `write()` after activation sends 0.0 rad to every motor.',
        "The forgetful board drives both motors to 0 rad at the board's speed limit the moment it becomes active, with no controller running at all: on a real arm that is a swing into whatever is nearby.",
        'A controller may run slower than the manager: `update_rate: 30` under a 100 Hz manager.',
        'The rolling manager runs it every `round(100 / 30) = 3` cycles, so its real rate is 100 / 3 = 33 Hz (it logs that), and its `update()` receives the longer `period`.',
        '**A path tolerance violation aborts the goal.** A faster move (back home in 0.6 s) with a path tolerance on `shoulder_lift_joint`, sent with the goal, of a quarter of the largest error it showed above.',
        '`parallel_gripper_action_controller/GripperActionController` drives one joint (here `finger_joint`, the finger opening in m, stroke 0 to 0.04 m) through the `~/gripper_cmd` action (control_msgs/ParallelGripperCommand).',
        'Below, a 3 cm box stands on a table between the open fingers.',
        "The experiment (`robocourse.control.wall_push`): a table 4 cm below the gripper's tool centre point; the trajectory asks the tool to go 8 cm down in 2 s, to a point 4 cm *below* the table's surface.",
        "**Send** builds a one-point `JointTrajectory` to the sliders' pose, sends it as a `FollowJointTrajectory` goal with the duration you pick, runs the manager until the result arrives and draws the arm live; the result line shows what the JTC answered (try a 0.3 s move with a path tolerance, or a pose beyond a joint limit).",
    ],
    'chapters/05_hardware_drivers.ipynb': [
        '| transport | UDP, 1 kHz, synchronous | TCP: RTDE state stream 500 Hz + servoj targets |',
    ],
    'chapters/90_appendix_bus_api.ipynb': [
        'A *sensor* publishes a sine wave at 100 Hz; a *controller* subscribes.',
        '## Simulated time: 10 s in a fraction of a second',
        '`spin_for(10.0)` runs every callback due in the next 10 s of *simulated* time, in deadline order, jumping the clock whenever nothing is ready.',
        'Below: one RELIABLE publisher at 100 Hz, a BEST_EFFORT and a RELIABLE KEEP_ALL subscription, 20 % loss, 2 ms delay, 10 s of simulated time; the seed makes the run repeatable.',
    ],
    'solutions/00_setup_exercises.ipynb': [
        "The seed demo's target: at 1 kHz the worst wake-up latency stays under 5 % of the period.",
    ],
    'solutions/01_realtime_exercises.ipynb': [
        'At 1 kHz a controller has one period to compute — minus the time the loop wakes up late.',
        "And `meets_5_percent(latency_ns, period_ns)`: the seed's rule, *maximum* latency at most 5 % of the period.",
        "**Predict, then verify.** Measure this machine's hybrid loop, predict the budget at p99, then give the loop a controller that computes for 80 % of that budget.",
        "Prediction: at most about 1 % of the iterations should overrun (those whose latency was above p99) — unless the machine's tail changed between the two runs, which is itself worth seeing.",
    ],
    'solutions/02_pendulum_exercises.ipynb': [
        '- `imu`: 1 kHz samples consumed by a balance controller;',
    ],
    'solutions/04_ros2_control_exercises.ipynb': [
        '- the controller manager at **200 Hz**;',
        '- `arm_controller`, a `joint_trajectory_controller/JointTrajectoryController` on `joint1`, `joint2` commanding `position` and reading `position` and `velocity`, with `constraints`: `goal_time` 1.0 s and a `goal` tolerance of 0.01 rad for each joint;',
        'Choose the gains so that the tool yields `deflection` (m) at rest, does not overshoot it, and settles (within 2 %) in at most `settle` s.',
    ],
    'solutions/05_hardware_drivers_exercises.ipynb': [
        "The Franka-style box sends a STATE every 1 ms and wants a COMMAND carrying that state's `seq` before its next tick (`robocourse.drivers.franka_protocol` documents the bytes; use its `HEADER`, `state_struct(n)`, `encode_command` and constants).",
    ],
    'solutions/07_graph_across_processes_exercises.ipynb': [
        '| 17-32 | the GID, 16 bytes |',
        "Anything that is not this 33-byte form (for example rmw_zenoh's pre-2025 attachment, 77 bytes with field names inside) must raise `ValueError` naming the length.",
    ],
}


# -- the rule itself: what it catches and what it allows ------------------------------------------

@pytest.mark.parametrize("sentence,kind", [
    ("with a 10 µs median and a millisecond worst case, the distribution is one bar.", "figure"),
    ("The loop woke 88 us late on average.", "figure"),
    ("It took 2.5 ms.", "figure"),
    ("A ratio near 100% means nothing was lost.", "figure"),
    ("The arm moved 1.5 cm.", "figure"),
    ("The fingers rotated the box by 41° and pushed with 112 N.", "figure"),
    ("The gap was 2-3 ms.", "figure"),
    ("Inference in the thread made the loop 29.7x slower.", "figure"),
    ("Trusting the mean: the mean met the budget in 0 of 9 runs.", "run count"),
    ("spin is punctual, and it burns all the CPU time it gets.", "verdict"),
    ("The hybrid wait has a lower median latency than sleep.", "verdict"),
    ("Heavier filtering gives a larger final distance than light filtering.", "verdict"),
    ("SCHED_FIFO makes no difference to the tail here.", "verdict"),
])
def test_the_rule_catches_measured_figures_and_verdicts(sentence, kind):
    found = check_sentence(sentence)
    assert kind in [v.kind for v in found], (sentence, found)


@pytest.mark.parametrize("sentence", [
    "The loop holds the mutex for `2 ms` at a time in a `1 kHz` loop.",            # settings as code
    "Feed both a constant error at dt = 1 ms and period = 1 ms.",                  # assignments
    "The pendulum ($L = 0.5$ m, $m = 0.01$ kg) is linearised about upright.",      # math
    "A stock kernel reached 2.75 ms (source: ROS 2 docs, Real-time programming in ROS 2).",
    "PREEMPT_RT bounds it to about 130 us, quoted from the ROS 2 real-time benchmark page.",
    "Whether spin's p99 came out lower than sleep's here is printed above.",      # holds either way
    "If the hog catches the holder, the loop waits longer than the hold.",         # a condition
    "A real-time thread has no timer slack, so its sleep is not stretched.",       # no comparison
    "Chapter 2 builds on section 3 and exercise 4 (2 points).",                    # numbers without units
    "```\nrobocourse rttest -i 20000 -s fifo\n```",                                 # fenced code
])
def test_the_rule_allows_definitions_settings_quotes_and_hedged_prose(sentence):
    assert check_markdown(sentence) == [], check_markdown(sentence)


def test_sentences_split_on_sentence_ends_list_items_and_headings():
    md = "## 2.5 Heading\n\nFirst one. Second\none continues.\n- item `a. B` stays\n- next: e.g. this"
    assert sentences(md) == ["## 2.5 Heading", "First one.", "Second one continues.", "- item `a. B` stays",
                             "- next: e.g. this"]


def test_a_quote_label_needs_a_source():
    assert check_sentence("It took 2.75 ms (source: ).")             # an empty label is no label
    assert not check_sentence("It took 2.75 ms (source: ROS docs).")


# -- every chapter and solution notebook ----------------------------------------------------------

def test_the_known_list_names_only_existing_notebooks():
    assert set(KNOWN_VIOLATIONS) <= set(NOTEBOOKS), set(KNOWN_VIOLATIONS) - set(NOTEBOOKS)


@pytest.mark.parametrize("notebook", NOTEBOOKS)
def test_markdown_holds_no_measured_figure_or_verdict(notebook):
    found = notebook_violations(ROOT / notebook)
    known = KNOWN_VIOLATIONS.get(notebook, [])
    new = sorted({str(v) for v in found if v.sentence not in known})
    assert not new, (f"{notebook}: markdown states a measured figure or verdict (render it with "
                     "robocourse.notebook.claim, write a setting as `code` or `name = value`, or label a quote "
                     "'(source: ...)'):\n  " + "\n  ".join(new))
    fixed = [s for s in known if s not in {v.sentence for v in found}]
    assert not fixed, (f"{notebook}: these known violations are fixed (or reworded): delete them from "
                       "KNOWN_VIOLATIONS in tests/test_chapter_markdown.py:\n  " + "\n  ".join(fixed))
