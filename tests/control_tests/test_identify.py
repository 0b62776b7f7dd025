"""labkit.control: fitting first/second-order models with dead time, and step tests on the virtual arm.

(The folder is not ``tests/control``: on the test path that name would shadow python-control.)
"""

import math

import numpy as np
import pytest

from labkit.control import StepFit, fit_step_response, model_response, rate_limited_steps, record_step
from labkit.control._identify import _discrete
from labkit.exceptions import DeviceError, LabkitError, MeasurementError, OptionError


def _truth(order=2, gain=0.5, wn=25.0, zeta=0.6, delay=0.02, offset=0.1):
    return StepFit(order, gain, wn, zeta if order == 2 else None, delay, offset, 0.0, {}, 0)


@pytest.mark.parametrize("order, zeta", [(1, None), (2, 0.3), (2, 1.0), (2, 2.5)])
@pytest.mark.parametrize("hold", ["zoh", "foh"])
def test_discretisation_matches_scipy(order, zeta, hold):
    from scipy.signal import cont2discrete

    wn, h = 20.0, 1e-3
    num, den = ([wn], [1.0, wn]) if order == 1 else ([wn * wn], [1.0, 2 * zeta * wn, wn * wn])
    bd, ad, _ = cont2discrete((num, den), h, method=hold)
    b, a = _discrete(order, wn, zeta, h, hold)
    assert np.allclose(a, ad, atol=1e-12)
    assert np.allclose(b[-len(np.ravel(bd)):], np.ravel(bd), atol=1e-12)


def test_step_model_matches_python_control():
    import control

    t = np.arange(-0.1, 0.6, 0.005)
    fit = _truth()
    tt, yc = control.step_response(fit.transfer_function(delay_order=0), T=np.arange(0.0, 0.6, 1e-4))
    expected = fit.offset + np.interp(t - fit.delay, tt, yc, left=0.0)
    assert np.max(np.abs(fit.predict(t) - expected)) < 1e-9


@pytest.mark.parametrize("order", [1, 2])
def test_fit_recovers_parameters_with_noise(order):
    rng = np.random.default_rng(7)
    t = np.sort(rng.uniform(-0.1, 0.8, 300))
    truth = _truth(order)
    y = truth.predict(t) + rng.normal(0.0, 0.002, t.size)
    fit = fit_step_response(t, y, order=order)
    for name in ("gain", "wn", "delay"):
        err = abs(getattr(fit, name) - getattr(truth, name))
        assert err < 4 * fit.uncertainty[name] + 1e-9, name
    if order == 2:
        assert abs(fit.zeta - truth.zeta) < 4 * fit.uncertainty["zeta"]
    assert fit.residual == pytest.approx(0.002, rel=0.2)
    assert list(fit.to_dataframe()["parameter"]) == (
        ["gain", "wn", "zeta", "delay", "offset"] if order == 2 else ["gain", "wn", "delay", "offset"])


def test_fit_with_an_arbitrary_command():
    t = np.linspace(0.0, 2.0, 401)
    u = np.where(t < 0.5, 0.0, np.where(t < 1.2, 1.0, -0.5)) + 0.3 * np.sin(7 * t) * (t > 0.5)
    y = model_response(t, u, 2, 1.5, 12.0, 0.35, 0.03, -0.2)
    fit = fit_step_response(t, y, u=u)
    assert (fit.gain, fit.wn, fit.zeta, fit.delay) == pytest.approx((1.5, 12.0, 0.35, 0.03), rel=1e-4, abs=1e-6)


def test_transfer_function_with_pade_delay():
    import control

    fit = _truth(offset=0.0)
    G = fit.transfer_function(delay_order=5)
    t = np.linspace(0.0, 0.6, 601)
    _, y = control.step_response(G, T=t)
    assert np.max(np.abs(y - fit.predict(t))) < 0.01 * fit.gain  # Padé: close, not exact
    assert float(G.dcgain()) == pytest.approx(fit.gain)
    with pytest.raises(OptionError, match="delay_order"):
        fit.transfer_function(delay_order=-1)


@pytest.mark.parametrize("t, y, u, order, match", [
    (np.arange(5.0), np.zeros(5), None, 2, "at least 8"),
    (np.arange(10.0), np.zeros(9), None, 2, "same shape"),
    (np.arange(10.0) - 2, np.r_[np.zeros(9), np.nan], None, 2, "finite"),
    (np.r_[np.arange(9.0), 3.0] - 2, np.zeros(10), None, 2, "increasing"),
    (np.arange(10.0) + 1, np.zeros(10), None, 2, "t = 0"),
    (np.arange(10.0), np.zeros(10), np.ones(10), 2, "changes"),
    (np.arange(10.0), np.zeros(10), np.ones(4), 2, "shape"),
    (np.arange(10.0) - 2, np.zeros(10), None, 3, "order 1 or 2"),
])
def test_bad_input_is_a_labkit_error(t, y, u, order, match):
    with pytest.raises(LabkitError, match=match):
        fit_step_response(t, y, u=u, order=order)


def test_rate_limited_steps():
    t = np.linspace(0.0, 1.0, 11)
    u = rate_limited_steps(t, 1.0, [(0.0, 2.0), (0.5, 1.0)], 5.0)
    assert u.tolist() == pytest.approx([1.0, 1.5, 2.0, 2.0, 2.0, 2.0, 1.5, 1.0, 1.0, 1.0, 1.0])


@pytest.mark.parametrize("seed, joint, degrees", [(0, "base_yaw", 30.0), (1, "shoulder_pitch", -30.0),
                                                  (2, "elbow_pitch", 30.0)])
def test_step_on_the_virtual_arm_recovers_the_servo_model(seed, joint, degrees):
    """Acceptance: wn and zeta of the virtual servo within 5 % from a step with the board's feedback noise."""
    from labkit.arm import Arm
    from labkit.arm.board import PhysicsConfig

    truth = PhysicsConfig()
    with Arm("arduino_arm_3dof", f"sim://?clock=lockstep&seed={seed}") as arm:
        arm.move_joints(np.radians([90.0, 60.0, 90.0]), wait=True)
        limits, timeout = arm.speed_limits(), arm.status().timeout
        rec = record_step(arm, joint, math.radians(degrees))
        assert arm.speed_limits() == limits and arm.status().timeout == timeout  # restored
        assert arm.robot.links[0].max_velocity is not None
    fit = rec.fit()
    assert fit.wn == pytest.approx(truth.natural_frequency, rel=0.05)
    assert fit.zeta == pytest.approx(truth.damping_ratio, rel=0.05)
    assert fit.gain == pytest.approx(1.0, rel=0.03)
    assert fit.residual < 3 * math.pi / 1023  # about the ADC's noise and resolution (1 count = pi/1023 rad)


def test_record_step_refuses_before_moving():
    from labkit.arm import Arm

    with Arm("arduino_arm_3dof", "sim://?clock=lockstep") as arm:
        arm.move_joints(np.radians([90.0, 170.0, 90.0]), wait=True)
        with pytest.raises(LabkitError, match="limit"):
            record_step(arm, 1, math.radians(30))
        with pytest.raises(OptionError, match="joint index"):
            record_step(arm, "wrist", 0.1)
        with pytest.raises(OptionError, match="amplitude"):
            record_step(arm, 0, 0.0)
        assert np.allclose(arm.commanded_joints(), np.radians([90.0, 170.0, 90.0]))


def test_record_step_changes_nothing_of_the_arm_even_when_the_step_fails(monkeypatch):
    """Issue 39: the step lifts the board's LIMITS through explicit arguments; the arm's robot is never swapped."""
    from labkit.arm import Arm

    with Arm("arduino_arm_3dof", "sim://?clock=lockstep") as arm:
        arm.move_joints(np.radians([90.0, 60.0, 90.0]), wait=True)
        robot, board = arm.robot, arm.port.board.executor
        limits, timeout = arm.speed_limits(), arm.status().timeout
        assert (board.vmax, board.amax) == limits and all(v > 0 for v in limits[0])
        seen = {}

        def failing_stream(duration, *, hz=50):
            seen.update(robot=arm.robot, vmax=list(board.vmax), timeout=arm.status().timeout)
            raise DeviceError("the link dropped mid-step")

        monkeypatch.setattr(arm, "stream", failing_stream)
        with pytest.raises(DeviceError, match="mid-step"):
            record_step(arm, "shoulder_pitch", math.radians(20))
        assert seen == {"robot": robot, "vmax": [0, 0, 0], "timeout": 0.0}  # lifted on the board only, during the step
        assert arm.robot is robot and arm.robot.links[0].max_velocity is not None  # the same robot, untouched
        assert (board.vmax, board.amax) == limits and arm.status().timeout == timeout  # the board's limits back
        with pytest.raises(LabkitError, match="speed limit"):  # and the host checks them again
            arm.move_joints(np.radians([90.0, 80.0, 90.0]), duration=0.01)


def test_the_speed_limits_an_arm_sends_and_checks_are_explicit_arguments():
    from labkit.arm import Arm

    with Arm("arduino_arm_3dof", "sim://?clock=lockstep") as arm:
        board = arm.port.board.executor
        for bad in (([0, 0], [0, 0, 0]), "none", ([0, 0, -1], [0, 0, 0]), ([0, 0, 0.5], [0, 0, 0]), ([0] * 3,)):
            with pytest.raises(OptionError, match="expected"):
                arm.sync_calibration(speed_limits=bad)
            with pytest.raises(OptionError, match="expected"):
                arm.run_trajectory([], speed_limits=bad)
        assert (board.vmax, board.amax) == arm.speed_limits()  # nothing sent
        arm.sync_calibration(speed_limits=([0, 1000, 0], [0, 0, 5000]))
        assert (board.vmax, board.amax) == ([0, 1000, 0], [0, 0, 5000])
        assert arm.speed_limits() == ([30000] * 3, [150000] * 3)  # the host's robot file limits are unchanged
