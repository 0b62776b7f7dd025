"""labkit.control: joint plants from the dynamics and PID design with python-control."""

import numpy as np
import pytest

from labkit.control import StepFit, design_pid, joint_plant
from labkit.dynamics import gravity_torques, mass_matrix
from labkit.exceptions import LabkitError
from labkit.robot import Robot


def test_joint_plant_from_the_dynamics():
    puma = Robot.load("puma560")
    q = np.array([0.0, 0.5, 0.0, 0.0, 0.0, 0.0])
    G = joint_plant(puma, q, 1)
    m, b, k = np.asarray(G.den[0][0], dtype=float) / float(G.num[0][0][0])
    assert m == pytest.approx(mass_matrix(puma, q)[1, 1])
    assert b == pytest.approx(puma.links[1].motor.gear_ratio ** 2 * puma.links[1].motor.viscous)
    dq = np.array([0.0, 1e-3, 0.0, 0.0, 0.0, 0.0])  # gravity stiffness: a coarser difference agrees
    assert k == pytest.approx((gravity_torques(puma, q + dq)[1] - gravity_torques(puma, q - dq)[1]) / 2e-3, rel=1e-4)
    with pytest.raises(LabkitError, match="joint index"):
        joint_plant(puma, q, 6)


def test_pid_design_against_python_control():
    import control

    G = joint_plant(Robot.load("puma560"), [0.0, 0.5, 0.0, 0.0, 0.0, 0.0], 1)
    d = design_pid(G, kp=400.0, ki=100.0, kd=40.0)
    s = control.tf("s")
    T = control.feedback((400 + 100 / s + 40 * s / (d.derivative_filter * s + 1)) * G, 1)
    t = np.linspace(0.0, 2.0, 401)
    assert np.allclose(d.step(t), control.step_response(T, T=t).outputs, atol=1e-6)
    assert d.stable and 30 < d.phase_margin < 90
    gains, poles = d.root_locus([0.001, 1.0])
    assert np.max(np.real(poles[0])) > 0 and np.max(np.real(poles[1])) < 0  # too little gain: unstable
    assert set(d.to_dataframe()["quantity"]) >= {"phase margin [deg]", "Overshoot [%]"}


def test_pid_on_an_identified_servo_and_bad_gains():
    fit = StepFit(2, 1.0, 25.0, 0.8, 0.01, 0.0, 0.0, {}, 0)
    d = design_pid(fit, kp=1.0, ki=10.0)
    assert d.stable and d.step_info["Overshoot"] < 5 and d.step(np.array([0.0, 3.0]))[-1] == pytest.approx(1.0, abs=1e-3)
    unstable = design_pid(fit, kp=20.0)
    assert not unstable.stable and unstable.gain_margin < 1 and unstable.step_info == {}
    for bad in (dict(kp=0.0), dict(kp=1.0, ki=-1.0), dict(kp=float("nan"))):
        with pytest.raises(LabkitError):
            design_pid(fit, **bad)
