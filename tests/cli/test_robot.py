"""``ftc-mj robot check``: the table and warnings on stdout, exit 0; bad input one line, exit 2."""

from __future__ import annotations

from pathlib import Path

import pytest

from ftc_mj.cli.main import main
from ftc_mj.robot.packages import resolve_package_uri

ROOT = Path(__file__).resolve().parents[2]
#: The URDF scenarios' arm comes from the optional extra ``robots`` (example-robot-data), not from ``test``.
needs_example_robot_data = pytest.mark.skipif(
    resolve_package_uri("package://example-robot-data/robots/ur_description/urdf/ur5_robot.urdf") is None,
    reason="example-robot-data is not installed (pip install -e '.[robots]')")


@needs_example_robot_data
def test_check_a_scenario_prints_every_joint(capsys):
    assert main(["robot", "check", str(ROOT / "scenarios" / "robots" / "ur5_urdf.yaml")]) == 0
    out = capsys.readouterr().out
    for joint in ("shoulder_pan_joint", "elbow_joint", "wrist_3_joint"):
        assert f"\n{joint} " in out
    assert "M_jj(q0)" in out and "peak tau_ref" in out and "smallest eigenvalue of M(q0)" in out
    assert "warning: no joint has armature" in out  # the URDF carries none


def test_check_a_robot_file(capsys):
    assert main(["robot", "check", str(ROOT / "models" / "puma560.xml")]) == 0
    out = capsys.readouterr().out
    assert "joint1" in out and "no warnings" in out and "peak tau_ref" in out


@needs_example_robot_data
def test_check_with_set(capsys):
    scenario = str(ROOT / "scenarios" / "robots" / "ur5_urdf.yaml")
    assert main(["robot", "check", scenario, "--set", "robot.armature=0.1"]) == 0
    assert "no joint has armature" not in capsys.readouterr().out


def test_bad_input_is_one_line_exit_2(tmp_path, capsys):
    assert main(["robot", "check", str(tmp_path / "nothing.urdf")]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and err.startswith("error: ") and "not found" in err
    assert main(["robot", "check", str(ROOT / "models" / "puma560.xml"), "--set", "seed=1"]) == 2
    assert "--set" in capsys.readouterr().err


@pytest.mark.slow  # a closed-loop run of seconds
def test_run_prints_the_checks_warnings_in_short_and_the_saturation(capsys):
    scenario = str(ROOT / "scenarios" / "robots" / "ur5e_fault.yaml")
    assert main(["run", scenario, "--no-record", "--duration", "0.3", "--set", "robot.torque_limits=5"]) == 0
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    gravity = [line for line in lines if "gravity alone needs" in line]
    assert len(gravity) == 2 and all("(heuristic" not in line and "ftc-mj robot check" in line for line in gravity)
    saturated = [line for line in lines if "clipped at the torque limits" in line]
    assert len(saturated) == 1 and "shoulder_lift_joint" in saturated[0], lines
    assert "saturation_time" in captured.out  # nonzero: in the summary table
    # 4 s: the start transient clips the command for 0.14 s (the nominal damping at the observers' estimate)
    assert main(["run", scenario, "--no-record", "--duration", "4.0", "--variant", "proposed"]) == 0
    captured = capsys.readouterr()
    # The shipped arm: no warning (its start transient's clipping, 2-4% of these 4 s, is in the table alone).
    assert "warning" not in captured.err
    # The NFTSMC without compensation (switching gain 160 rad/s^2) is clipped from the start: said so.
    assert main(["run", scenario, "--no-record", "--duration", "0.3", "--variant", "nftsmc"]) == 0
    saturated = [line for line in capsys.readouterr().err.splitlines() if "clipped" in line]
    assert len(saturated) == 1 and "nftsmc shoulder_lift_joint" in saturated[0]
