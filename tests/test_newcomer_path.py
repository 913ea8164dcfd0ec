"""The newcomer's path (issue 25): each bad input a first-time user met gets the value, the rule and the fix,
before any work is done; nothing is clamped or accepted silently, no traceback."""

from __future__ import annotations

import math
import os
import subprocess
from pathlib import Path

import pytest

from robocourse.cli import main

ROOT = Path(__file__).resolve().parents[1]


def _err(capsys) -> str:
    return capsys.readouterr().err


# -- make lab ------------------------------------------------------------------------------------

@pytest.mark.skipif(os.geteuid() != 0, reason="the root check only fires as root (CI runs as root)")
def test_make_lab_as_root_stops_first_and_says_what_to_do():
    out = subprocess.run(["make", "-s", "lab-user"], cwd=ROOT, capture_output=True, text=True, timeout=30)
    assert out.returncode == 2
    assert "you are root (uid 0)" in out.stderr and "Jupyter refuses to run as root" in out.stderr
    assert "make lab LAB_FLAGS=--allow-root" in out.stderr
    # 'make lab' checks before anything else runs (no venv build, no jupyter)
    dry = subprocess.run(["make", "-n", "lab"], cwd=ROOT, capture_output=True, text=True, timeout=30)
    assert dry.stdout.index("you are root") < dry.stdout.index("jupyter lab")
    allowed = subprocess.run(["make", "-s", "lab-user", "LAB_FLAGS=--allow-root"], cwd=ROOT, capture_output=True,
                             text=True, timeout=30)
    assert allowed.returncode == 0 and allowed.stderr == ""


def test_lab_kernels_use_ipc_unless_the_socket_path_would_be_too_long(tmp_path):
    from robocourse.cli.lab import ipc_transport_fits, server_config

    assert server_config(tmp_path, tmp_path)["KernelManager"] == {"transport": "ipc"}
    assert "KernelManager" not in server_config(tmp_path, tmp_path, ipc=False)
    assert ipc_transport_fits("/run/user/1000/jupyter/runtime") == (True, "")
    ok, why = ipc_transport_fits("/home/" + "x" * 60)
    assert not ok and "over the 107 a Unix socket path allows" in why and "JUPYTER_RUNTIME_DIR" in why


def test_headless_runs_use_ipc_and_print_no_tcp_warning(tmp_path, capfd):
    import nbformat

    from robocourse.notebook.run import execute

    nb = nbformat.v4.new_notebook(metadata={"kernelspec": {"name": "python3", "display_name": "Python 3"}})
    nb.cells.append(nbformat.v4.new_code_cell("import os; print(sorted(os.listdir('.')))"))
    path = tmp_path / "probe.ipynb"
    nbformat.write(nb, path)
    ran, _ = execute(path)
    assert ran.cells[0].outputs[0]["text"].strip() == "['probe.ipynb']"      # no socket files left beside it
    assert "without encryption" not in capfd.readouterr().err


# -- robocourse control --------------------------------------------------------------------------

def test_control_view_writes_a_default_file_and_refuses_a_wrong_one(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["control", "view"]) == 0
    assert (tmp_path / "rrbot_system.svg").read_text().lstrip().startswith("<")
    assert main(["control", "view", "picture.png"]) == 2
    assert "output 'picture.png': view writes an SVG picture; name the file .svg, e.g. picture.svg" in _err(capsys)
    assert main(["control", "view", str(tmp_path / "missing" / "x.svg")]) == 2
    assert "its folder does not exist" in _err(capsys)


def test_control_spawn_of_an_undeclared_controller_names_the_declared_ones(capsys):
    assert main(["control", "list_controllers", "--spawn", "no_such"]) == 2
    err = _err(capsys)
    assert "--spawn 'no_such': no such controller in" in err and "rrbot_controllers.yaml" in err
    assert "declared there: forward_position_controller, joint_state_broadcaster" in err
    assert "Traceback" not in err


# -- robocourse mycar ----------------------------------------------------------------------------

def test_mycar_record_into_a_folder_is_refused_before_the_mission(tmp_path, capsys):
    assert main(["mycar", "demo", "--record", str(tmp_path)]) == 2
    err = _err(capsys)
    assert f"--record {str(tmp_path)!r}: is a folder; the recording is one MCAP file" in err
    assert f"--record {tmp_path / 'mission.mcap'}" in err
    assert main(["mycar", "demo", "--record", str(tmp_path / "no" / "m.mcap")]) == 2
    assert "does not exist" in _err(capsys)


# -- library calls -------------------------------------------------------------------------------

def test_set_affinity_with_text_names_the_rule():
    from robocourse.rt import settings

    with pytest.raises(ValueError, match=r"set_affinity\(cpus='0'\): CPU numbers are ints.*int\('0'\)"):
        settings.set_affinity("0")
    with pytest.raises(ValueError, match="CPU numbers are ints"):
        settings.set_affinity([0, "1"])


def test_textbook_pid_with_text_gains_names_the_rule():
    from robocourse.pendulum.pid import TextbookPID

    with pytest.raises(ValueError, match=r"TextbookPID\(kp='1'\): kp must be a number.*float\('1'\)"):
        TextbookPID("1")
    with pytest.raises(ValueError, match=r"u_min must be below u_max"):
        TextbookPID(1.0, u_min=1.0, u_max=-1.0)


# -- robocourse pendulum demo / rttest -----------------------------------------------------------

def test_pendulum_setpoint_outside_the_seed_range_is_refused_not_clamped(capsys):
    assert main(["pendulum", "demo", "--setpoint", "10"]) == 2
    err = _err(capsys)
    assert "--setpoint '10': the seed's angle runs from 0 to pi = 3.1416 rad" in err
    assert "its motor clamps anything outside it" in err and "e.g. --setpoint 1.3" in err
    from robocourse.pendulum.demo import run_realtime, teleop

    with pytest.raises(ValueError, match=r"setpoint=10.0: the seed's angle runs from 0 to pi"):
        run_realtime(10, setpoint=10.0)
    from robocourse.bus import Context

    with pytest.raises(ValueError, match=r"setpoint=-1: the seed's angle"):
        teleop(Context(use_sim_time=True), -1, verbose=False)
    from robocourse.pendulum.demo import run_simulated

    assert run_simulated(0.01, setpoint=math.pi / 2)["setpoints"] == [math.pi / 2]   # the range's inside still runs


def test_pendulum_demo_help_lists_its_options_and_bogus_names_its_own_usage(capsys):
    assert main(["pendulum", "demo", "--help"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: robocourse pendulum demo [-i ITERATIONS]")
    assert "--setpoint RAD" in out and "-t P" in out and "default 98" in out and "``" not in out
    assert main(["pendulum", "demo", "--bogus"]) == 2
    err = _err(capsys)
    assert "unknown option '--bogus'. usage: robocourse pendulum demo" in err and "robocourse rttest" not in err


def test_rttest_priority_99_is_refused_as_its_help_says(capsys):
    assert main(["rttest", "-t", "99", "-i", "10"]) == 2
    assert "-t '99': priority 99 is where the kernel's watchdog" in _err(capsys)
    assert main(["rttest", "-h"]) == 0
    assert "real-time priority 1..98" in capsys.readouterr().out


# -- robocourse release --------------------------------------------------------------------------

def test_release_force_into_a_folder_that_is_not_an_edition_is_refused(tmp_path):
    from robocourse import release

    target = tmp_path / "mine"
    target.mkdir()
    (target / "thesis.tex").write_text("mine\n")
    with pytest.raises(ValueError, match=r"holds 1 entries \(e.g. 'thesis.tex'\) but no .robocourse-edition.json"):
        release.release(target, root=ROOT, force=True)
    assert sorted(p.name for p in target.iterdir()) == ["thesis.tex"]     # nothing written
