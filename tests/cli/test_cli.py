"""Tests of the ``labkit robots`` and ``labkit fk`` subcommands."""

import re
from pathlib import Path

import numpy as np
import pytest

from labkit.cli import main


def _numbers(text):
    return [float(v) for v in re.findall(r"-?\d+(?:\.\d+)?(?:e-?\d+)?", text)]


def test_robots_lists_every_bundled_robot(capsys):
    assert main(["robots"]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    assert lines[0].split() == ["name", "joints", "DH", "description"]
    for name, n, conv in [
        ("arduino_arm_3dof", "3", "modified"),
        ("puma600_seed002", "6", "standard"),
        ("rpp_seed002", "3", "standard"),
        ("puma560", "6", "standard"),
        ("planar3r_seed004", "3", "standard"),
    ]:
        row = next(line for line in lines if line.split()[0] == name)
        assert row.split()[1:3] == [n, conv]


def test_robots_reports_a_broken_file_without_hiding_the_rest(tmp_path, monkeypatch, capsys):
    (tmp_path / "broken.toml").write_text('name = "broken"\nconvention = "dh"\n')
    monkeypatch.setenv("LABKIT_ROBOT_PATH", str(tmp_path))
    assert main(["robots"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"broken\s+\?\s+\?\s+ERROR: .*broken.toml: field 'convention'", out)
    assert "arduino_arm_3dof" in out


def test_fk_seed000_in_degrees_and_mm(capsys):
    assert main(["fk", "arduino_arm_3dof", "5", "0", "0", "--deg", "--mm"]) == 0
    out = capsys.readouterr().out
    first = out.splitlines()[0]
    assert first.startswith("position [mm]:")
    x, y, z = _numbers(first.split(":", 1)[1])
    assert (x, y, z) == pytest.approx((272.957, 23.8807, 0.0), abs=1e-3)
    assert "transform (rotation | position [mm])" in out


def test_fk_puma600_seed002_radians(capsys):
    q = [str(np.pi / 6)] * 6
    assert main(["fk", "puma600_seed002", *q, "--mm"]) == 0
    out = capsys.readouterr().out
    rows = [_numbers(line) for line in out.splitlines()[2:5]]
    published = [
        [0.2522, 0.1044, 0.9620, 719.3029],
        [-0.7874, -0.5558, 0.2667, 602.9285],
        [0.5625, -0.8248, -0.0580, 541.2981],
    ]
    assert np.allclose(rows, published, atol=6e-4)


def test_fk_prismatic_joints_in_mm(capsys):
    assert main(["fk", "rpp_seed002", "0", "1000", "1000", "--mm"]) == 0
    out = capsys.readouterr().out
    assert _numbers(out.splitlines()[0].split(":", 1)[1]) == pytest.approx([1000, 0, 1500])


def test_fk_robot_file_path(tmp_path, capsys):
    from labkit.robot import Robot

    path = tmp_path / "copy.toml"
    Robot.load("planar3r_seed004").to_toml(path)
    assert main(["fk", str(path), "0", "0", "1.5707963267948966"]) == 0
    assert _numbers(capsys.readouterr().out.splitlines()[0].split(":", 1)[1]) == pytest.approx([0.35, 0.12, 0])


@pytest.mark.parametrize(
    "argv, message",
    [
        (["fk", "arduino_arm_3dof", "5", "0", "--deg"], "has 3 joints; expected 3 joint values, got 2"),
        (["fk", "arduino_arm_3dof", "5", "0", "200", "--deg"], r"joint 3 \(elbow_pitch\) = 200 deg outside"),
        (["fk", "no_such_robot", "1", "2", "3"], "unknown robot; expected a file path or one of: al5d, arduino_arm_3dof"),
    ],
)
def test_fk_errors_exit_2_with_message(argv, message, capsys):
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert re.search(r"labkit fk: error: .*" + message, captured.err)


def test_fk_requires_joint_values():
    with pytest.raises(SystemExit) as info:
        main(["fk", "arduino_arm_3dof"])
    assert info.value.code == 2


@pytest.mark.parametrize("argv", [
    ["tests/labs/robots/probe42/ur_like_mod.toml", "0", "-90", "0", "-90", "0", "0", "--deg"],  # x is 1.7e-16 m
    ["tests/labs/robots/probe42/prrr_rail.toml", "500", "0", "90", "-45", "--mm", "--deg"],  # a bottom row of -0.0
])
def test_fk_prints_round_off_as_zero(argv, capsys):
    """A coordinate the DH walk leaves at 1e-16 printed as ``x = -1.66533e-16``, rotation entries of -6e-17 and a
    bottom row of -0.0 as ``-0.000000``."""
    from labkit.kinematics import fk
    from labkit.robot import Robot, joints_from_display

    path = Path(__file__).parents[2] / argv[0]
    assert main(["fk", str(path), *argv[1:]]) == 0
    out = capsys.readouterr().out
    assert "e-" not in out and "-0.000000" not in out, out
    robot, mm = Robot.load(path), "--mm" in argv
    q = joints_from_display(robot, [float(v) for v in argv[1:1 + robot.n]])  # both arms: degrees, millimetres
    rows = np.array([_numbers(line) for line in out.splitlines()[2:6]])
    assert np.allclose(rows[:3, :3], fk(robot, q)[:3, :3], atol=1e-6)
    assert np.allclose(rows[:3, 3], fk(robot, q)[:3, 3] * (1e3 if mm else 1.0), atol=1e-3)
    assert rows[3].tolist() == [0, 0, 0, 1]
