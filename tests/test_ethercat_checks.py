"""Chapter 5's EtherCAT checks in the student's kernel: the solution scores full marks on fresh draws,
malformed answers are reported, the truth is the simulated bus. The plausible wrong answers with
their partial scores are the bank's (tests/banks/ch05_ethercat.py)."""

from pathlib import Path

import nbformat
import numpy as np
import pytest

from robocourse.grading import discover, exercises
from robocourse.grading.checks import get, run_check

ROOT = Path(__file__).resolve().parents[1]
SOL = ROOT / "solutions/05_hardware_drivers_exercises.ipynb"


def solution_namespace() -> dict:
    """The solution notebook's definitions (its code cells, minus the check/score calls)."""
    discover()
    ns: dict = {}
    for cell in nbformat.read(SOL, as_version=4).cells:
        if cell.cell_type == "code" and "check(" not in cell.source and "score(" not in cell.source:
            exec(cell.source, ns)
    return ns


@pytest.fixture(scope="module")
def solution():
    return solution_namespace()


def run(name, obj, seed=0):
    return run_check(get(name), obj, rng=np.random.default_rng(seed))


def test_every_check_of_ch05_is_called_in_the_exercises():
    called = exercises.checks_in(nbformat.read(SOL, as_version=4))
    assert called == ["ch05.fprd_frame", "ch05.expected_wkc", "ch05.cia402_enable", "ch05.franka_loop",
                      "ch05.ur_servo_loop"]
    assert sorted(called) == sorted(n for n in discover() if n.startswith("ch05."))


@pytest.mark.parametrize("name,obj", [("ch05.fprd_frame", "fprd_frame"), ("ch05.expected_wkc", "expected_wkc"),
                                      ("ch05.cia402_enable", "controlword_for")])
def test_solutions_score_full_marks(solution, name, obj):
    for seed in range(3):
        r = run(name, solution[obj], seed)
        assert r.passed and r.points == r.weight == 2, r.message


def test_the_solution_frame_is_the_golden_brd_shape_with_fprd_fields(solution):
    # hand-derived from the reference's golden BRD pair: same header, cmd 4, ADP 0x1001, ADO 0x0130
    raw = solution["fprd_frame"](0x1001, 0x0130, 2, 0)
    assert raw.hex() == ("ffffffffffff" "010101010101" "88a4" "0e10" "04" "00" "0110" "3001" "0200" "0000"
                         "0000" "0000") + "00" * 30
    assert len(raw) == 60


def test_fprd_through_the_library_encoder_scores_zero():
    from robocourse.ethercat.frames import Command, datagram, encode_frame
    from robocourse.ethercat.frames import Frame as EcFrame

    def delegated(station, register, length, idx):
        return encode_frame(EcFrame([datagram(Command.FPRD, station, register, length, idx)]))

    r = run("ch05.fprd_frame", delegated)
    assert not r.passed and r.points == 0


def test_fprd_returning_a_list_or_raising_is_reported_not_crashed():
    r = run("ch05.fprd_frame", lambda *a: [1, 2, 3])
    assert r.points == 0 and "must return bytes, got list" in r.message
    r = run("ch05.fprd_frame", lambda *a: 1 / 0)
    assert not r.passed and "raised ZeroDivisionError" in r.message


def test_wkc_ignoring_the_cut_cable_or_the_missing_dc_unit_scores_zero(solution):
    def no_cut(bus, d):
        return solution["expected_wkc"]({**bus, "connected": len(bus["slaves"])}, d)

    def all_dc(bus, d):
        return solution["expected_wkc"]({**bus, "slaves": [{**s, "dc": True} for s in bus["slaves"]]}, d)

    r = run("ch05.expected_wkc", no_cut)
    assert not r.passed and "cable cut after slave" in r.message
    r = run("ch05.expected_wkc", all_dc)
    assert not r.passed and "ado=0x0910" in r.message


def test_wkc_layouts_are_fresh_per_seed_and_the_truth_is_the_simulated_bus():
    from robocourse.ethercat.checks import _wkc_inputs, simulated_wkcs

    a, b = _wkc_inputs(np.random.default_rng(1)), _wkc_inputs(np.random.default_rng(2))
    assert a != b
    layout = {"slaves": [{"position": 0, "name": "RC1100", "station": 0x1001, "inputs": 0, "outputs": 0, "dc": True},
                         {"position": 1, "name": "RC-Servo", "station": 0x1002, "inputs": 13, "outputs": 13, "dc": True},
                         {"position": 2, "name": "RC1008", "station": 0x1003, "inputs": 1, "outputs": 0, "dc": False}],
              "connected": 3,
              "datagrams": [{"cmd": "BRD", "adp": 0, "ado": 0x0000, "length": 2},
                            {"cmd": "LRW", "logical": 0, "length": 27},
                            {"cmd": "BRD", "adp": 0, "ado": 0x0910, "length": 4},
                            {"cmd": "FPRD", "adp": 0x1003, "ado": 0x0910, "length": 4}]}
    # 3 slaves; LRW = 2 x 1 (outputs) + 2 (inputs); two DC units; the RC1008 has none
    assert simulated_wkcs(layout) == [3, 4, 2, 0]
    assert simulated_wkcs({**layout, "connected": 1}) == [1, 0, 1, 0]


def test_cia402_through_the_library_rule_scores_zero():
    from robocourse.ethercat.ros2_control import next_controlword

    r = run("ch05.cia402_enable", lambda sw: next_controlword(sw, 0, True))
    assert not r.passed and r.points == 0


def test_cia402_returning_garbage_is_reported(solution):
    r = run("ch05.cia402_enable", lambda sw: "0x0F")
    assert not r.passed and "a controlword is an int" in r.message
