"""labkit.control: resolved-rate Cartesian control, computed and run on virtual arms."""

import numpy as np
import pytest

from labkit.control import resolved_rate_trajectory, track_on_arm
from labkit.exceptions import LabkitError
from labkit.kinematics import fk_position
from labkit.motion import line_path
from labkit.robot import Robot

#: the stated tolerance: the sensed tool point stays within 5 mm of the commanded line
PATH_TOLERANCE = 5e-3


def test_kinematic_feedback_pulls_the_tool_onto_the_line():
    arm = Robot.load("arduino_arm_3dof")
    q0 = np.radians([70.0, 100.0, 110.0])
    p0 = fk_position(arm, q0)
    path = line_path(p0 + [0.01, 0.0, 0.0], p0 + [0.05, 0.05, 0.0])  # starts 10 mm off the path's start
    traj = resolved_rate_trajectory(arm, path, 2.0, q0, gain=20.0, dt=0.01)
    err = np.linalg.norm(fk_position(arm, traj.q) - traj.x, axis=-1)
    assert err[0] == pytest.approx(0.01)
    assert err[-1] < 1e-4 and np.all(err[50:] < 1e-3)
    drift = resolved_rate_trajectory(arm, path, 2.0, q0, gain=0.0, dt=0.01)  # no feedback: the offset stays
    assert np.linalg.norm(fk_position(arm, drift.q[-1]) - drift.x[-1]) > 5e-3


@pytest.mark.parametrize("robot, url, q0", [
    ("arduino_arm_3dof", "sim://?clock=lockstep&seed=1", [70.0, 100.0, 110.0]),
    ("so101", "sim://so101?bus=feetech&clock=lockstep", [10.0, 20.0, 30.0, 20.0, 0.0]),
])
def test_a_cartesian_line_is_kept_on_the_virtual_arm(robot, url, q0):
    """Acceptance: the measured tool point stays within PATH_TOLERANCE of the commanded line."""
    from labkit.arm import Arm

    with Arm(robot, url) as arm:
        q0 = np.radians(q0)
        p0 = fk_position(arm.robot, q0)
        path = line_path(p0, p0 + [0.05, 0.05, 0.0] if robot.startswith("arduino") else p0 + [0.03, 0.03, 0.0])
        rec = track_on_arm(arm, resolved_rate_trajectory(arm.robot, path, 2.0, q0), path)
    assert rec.t[-1] > 2.0 and len(rec.t) > 30
    assert np.max(rec.path_error) < PATH_TOLERANCE
    assert np.linalg.norm(rec.x_measured[-1] - path.points[-1]) < PATH_TOLERANCE  # it got to the end
    table = rec.to_dataframe()
    assert table["max [mm]"].iloc[0] == pytest.approx(1e3 * np.max(rec.path_error))


def test_bad_options_are_refused():
    arm = Robot.load("arduino_arm_3dof")
    path = line_path([0.1, 0.1, 0.0], [0.1, 0.15, 0.0])
    with pytest.raises(LabkitError, match="gain"):
        resolved_rate_trajectory(arm, path, 1.0, np.radians([90, 90, 90]), gain=-1.0)
    with pytest.raises(LabkitError, match="duration"):
        resolved_rate_trajectory(arm, path, 0.0, np.radians([90, 90, 90]))
    with pytest.raises(LabkitError, match="q0"):
        resolved_rate_trajectory(arm, path, 1.0, [0.0, 0.0])
