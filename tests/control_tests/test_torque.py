"""labkit.control: computed torque vs independent-joint PD, simulated on the dynamics."""

import numpy as np
import pytest

from labkit.exceptions import LabkitError
from labkit.control import computed_torque_controller, pd_controller, simulate_tracking
from labkit.motion import joint_trajectory
from labkit.robot import Robot


@pytest.fixture(scope="module")
def puma_runs():
    model = Robot.load("puma560")
    plant = model.with_payload(0.5)  # the model error: a 0.5 kg payload the controllers do not know
    traj = joint_trajectory(model, np.zeros(6), [0.5, -0.6, -0.8, 0.4, -0.5, 0.6], 1.5, law="quintic", dt=0.01)
    run = {}
    for name, ctl in [("computed torque", computed_torque_controller(model, traj, 100.0, 20.0, friction=False)),
                      ("pd", pd_controller(model, traj, 100.0, 20.0))]:
        run[name] = simulate_tracking(plant, traj, ctl, dt=0.01, friction=False)
    return run


def test_computed_torque_beats_pd_5x_under_a_payload_error(puma_runs):
    """Acceptance: RMS tracking error at least 5x smaller than PD with the same gains."""
    ct, pd = puma_runs["computed torque"], puma_runs["pd"]
    assert ct.rms_error * 5 <= pd.rms_error
    assert ct.max_error < 0.03  # rad
    table = ct.to_dataframe()
    assert list(table["joint"]) == list(Robot.load("puma560").joint_names)
    assert table["rms error [rad]"].max() <= ct.max_error


def test_computed_torque_with_the_exact_model_follows_the_error_equation():
    arm = Robot.load("arduino_arm_3dof")
    traj = joint_trajectory(arm, np.radians([90, 90, 90]), np.radians([120, 120, 130]), 1.0, law="quintic", dt=0.01)
    ctl = computed_torque_controller(arm, traj, 400.0, 40.0, friction=False)
    run = simulate_tracking(arm, traj, ctl, dt=0.01, friction=False, rtol=1e-9, atol=1e-11)
    assert run.max_error < 1e-5  # starts on the trajectory: e'' + kd e' + kp e = 0 keeps e = 0


def test_bad_gains_are_refused():
    arm = Robot.load("arduino_arm_3dof")
    traj = joint_trajectory(arm, np.radians([90, 90, 90]), np.radians([100, 100, 100]), 1.0)
    with pytest.raises(LabkitError, match="kp"):
        computed_torque_controller(arm, traj, [1.0, 2.0], 1.0)
    with pytest.raises(LabkitError, match="trajectory of 6 joints"):
        simulate_tracking(Robot.load("puma560"), traj, lambda t, q, qd: np.zeros(6))
