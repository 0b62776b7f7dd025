"""``labkit new`` on ten more held-out arms (``tests/labs/robots/probe42``): a cylindrical RPP with a negative quill
and reach, a gantry in metres with a reversed (flipped) axis, an RRPR SCARA in modified DH with negative d offsets, a
wrist-less RRP SCARA with a negative quill, a planar RR in cm with limits narrower than +-90 deg and a theta offset, a
4-DOF arm with narrow limits, a 5-DOF arm with an offset wrist, a UR-like 6R arm in modified DH, a rail-mounted PRRR
arm and an RP telescope whose travel does not contain 0. None has a servo table: every joint is an ideal actuator.

What they found: the joint move and the Cartesian line were planned faster than the virtual arm moves a joint the
robot file gives no speed limits (a UR-like wrist at 110 deg/s against the ideal actuator's 90 deg/s: 22 deg
behind); an ideal actuator braked to a stop at every 20 ms servo frame of a streamed plan, so it lagged v^2 / 2a
behind it (a gantry axis 22 mm, a rail 33 mm, within its limits); the FK plan's "joint moved" poses sat 2-3 deg from
home where home was near 30 % or 70 % of a joint's window; a gantry with joints named z, y, x lost its joint columns
in 01_robot_dh's FK table to the tool position's x, y, z (the calibration table and ``labkit fk``'s round-off are
tested in tests/measure and tests/cli).
"""

import math
from pathlib import Path

import numpy as np
import pytest

from labkit.robot import Robot, joints_from_display

PROBE = Path(__file__).parent / "robots" / "probe42"
ARMS = sorted(p.stem for p in PROBE.glob("*.toml"))


def test_the_probe_arms_are_there():
    assert len(ARMS) == 10


@pytest.fixture(scope="module")
def defaults():
    from labkit.labs import lab_defaults

    return {arm: lab_defaults(PROBE / f"{arm}.toml") for arm in ARMS}


@pytest.mark.parametrize("arm", ARMS)
def test_each_fk_pose_moves_its_joint_a_fifth_of_the_window_from_home(arm, defaults):
    robot = Robot.load(PROBE / f"{arm}.toml")
    poses = joints_from_display(robot, defaults[arm].parameters["poses"])
    home, moved = poses[0], poses[1:].reshape(robot.n, 2, robot.n)
    span = np.ptp(robot.joint_limits, axis=1)  # none of these arms has a servo window or endless joints
    rounding = np.where(robot.is_revolute, math.radians(1.0), 1e-3)  # poses are whole degrees / millimetres
    for j in range(robot.n):
        others = np.delete(moved[j] - home, j, axis=1)
        assert np.all(others == 0.0), f"{arm}: pose {j} moves only joint {j}"
        step = np.abs(moved[j][:, j] - home[j])
        assert np.all(step >= 0.2 * span[j] - rounding[j]), (arm, robot.joint_names[j], step / span[j])
        assert moved[j][0, j] < home[j] < moved[j][1, j] or moved[j][0, j] < moved[j][1, j], (arm, j)
        assert np.all(robot.within_limits(moved[j]))


@pytest.mark.parametrize("arm", ARMS)
def test_the_labs_plans_keep_within_the_speeds_the_virtual_arm_moves_at(arm, defaults):
    """The joint moves, line and arc as the 04_trajectory notebook plans them, at the lab's duration, against each
    joint's speed limits on the virtual arm (the robot file's, else an ideal actuator's defaults)."""
    from labkit.arm import ideal_speed_limits
    from labkit.motion import arc_path, cartesian_trajectory, joint_trajectory, line_path

    robot = Robot.load(PROBE / f"{arm}.toml")
    p = defaults[arm].parameters
    duration = p["duration"]
    home = joints_from_display(robot, p["home"])
    q0, q1 = joints_from_display(robot, p["move"])
    arc = p["arc"]
    plans = [joint_trajectory(robot, q0, q1, duration, law=law, dt=0.02) for law in ("cubic", "quintic")]
    line = np.asarray(p["line_mm"], float) / 1e3
    path = arc_path(np.asarray(arc["center_mm"]) / 1e3, arc["radius_mm"] / 1e3, math.radians(arc["start_deg"]),
                    math.radians(arc["sweep_deg"]), normal=arc.get("normal"))
    plans += [cartesian_trajectory(robot, shape, duration, dt=0.02, q_start=home)
              for shape in (line_path(line[0], line[1]), path)]
    vmax, amax = np.array([ideal_speed_limits(robot, j) for j in range(robot.n)]).T
    for traj in plans:
        assert np.all(np.abs(traj.qd).max(axis=0) <= vmax), (arm, np.abs(traj.qd).max(axis=0) / vmax)
        assert np.all(np.abs(traj.qdd).max(axis=0) <= amax), (arm, np.abs(traj.qdd).max(axis=0) / amax)


@pytest.mark.parametrize("arm", ["gantry_reversed", "prrr_rail", "ur_like_mod"])
def test_a_lab_joint_move_streamed_to_the_virtual_arm_is_followed_without_lag(arm, defaults):
    """The 04_trajectory notebook's run, read back while it streams: each ideal actuator stays within twice its settle
    tolerance of the plan (1 deg, 1 mm or three encoder counts; it lagged 22 mm, 33 mm and 22 deg behind)."""
    from labkit.arm import Arm, settle_tolerance
    from labkit.motion import joint_trajectory

    robot = Robot.load(PROBE / f"{arm}.toml")
    p = defaults[arm].parameters
    q0, q1 = joints_from_display(robot, p["move"])
    traj = joint_trajectory(robot, q0, q1, p["duration"], law="cubic", dt=0.02)
    with Arm(robot, f"sim://{PROBE / f'{arm}.toml'}?clock=lockstep&seed=0&calibrated=1") as board:
        board.set_host_timeout(5.0)
        board.move_joints(traj.q[0], wait=True)
        board.wait_settled(traj.q[0])
        samples = []
        t0 = board.status().t
        board.run_trajectory(traj, progress=lambda done, total: samples.append((board.status().t - t0,
                                                                                 *board.read_joints())), wait=True)
    s = np.array(samples)
    planned = np.column_stack([np.interp(s[:, 0], traj.t, traj.q[:, j]) for j in range(robot.n)])
    lag = np.abs(s[:, 1:] - planned).max(axis=0)
    assert len(s) > 20 and np.all(lag < 2 * settle_tolerance(robot)), dict(zip(robot.joint_names, lag.round(4)))


@pytest.mark.slow
@pytest.mark.notebooks
def test_a_gantry_whose_joints_are_named_x_y_z_keeps_its_joint_columns(tmp_path):
    """01_robot_dh's FK table put the tool position into columns "x [mm]", "y [mm]", "z [mm]": on a gantry whose
    joints are named z, y, x they replaced the joint values (a three-column table of tool positions)."""
    import pandas as pd
    from conftest import require

    require("papermill")
    from labkit.kinematics import fk_position
    from labkit.labs import new_lab
    from labkit.reports import render

    lab = new_lab(PROBE / "gantry_reversed.toml", tmp_path / "lab")
    results, _ = render([str(lab.folder / "01_robot_dh.ipynb")], tmp_path / "reports", jobs=1, pdf=False,
                        progress=None, timeout=300)
    assert results[0].ok, results[0].error
    table = pd.read_csv(tmp_path / "reports" / "lab" / "01_robot_dh_files" / "fk_poses.csv")
    robot = Robot.load(lab.robot_file)
    joints = [f"{name} [mm]" for name in robot.joint_names]
    assert joints == ["z [mm]", "y [mm]", "x [mm]"] and list(table.columns[:3]) == joints
    q = joints_from_display(robot, table[joints].to_numpy())
    assert np.allclose(table.iloc[:, 3:].to_numpy(), fk_position(robot, q) * 1e3, atol=0.01)
