"""Tests of calibrate's analytic parameter derivatives, and of the fit they drive against scipy's finite differences."""

import numpy as np
import pytest

from labkit.data import measurement_file
from labkit.kinematics import fk_position
from labkit.measure import apply_parameters, calibrate, parameter_names
from labkit.measure._errormodels import _covariance
from labkit.measure._parameters import _nominal, _position_derivatives
from labkit.robot import Convention, JointType, Link, Robot
from labkit.rotations import matrix_from_rpy


def _random_robot(rng, convention, n=5):
    """A robot with revolute and prismatic joints, one of them flipped, a rotated base and tool."""
    links = [Link(a=rng.uniform(0.05, 0.4), alpha=rng.choice([np.pi / 2, -np.pi / 2, rng.uniform(-np.pi, np.pi)]),
                  d=rng.uniform(0.05, 0.4), theta=rng.uniform(-np.pi, np.pi),
                  joint_type=JointType.PRISMATIC if k == 2 else JointType.REVOLUTE,
                  limits=(0.0, 1.0) if k == 2 else (-np.pi, np.pi), flip=k == 1)
             for k in range(n)]
    base, tool = np.eye(4), np.eye(4)
    base[:3, :3], tool[:3, :3] = matrix_from_rpy(rng.uniform(-np.pi, np.pi, size=(2, 3)))
    base[:3, 3], tool[:3, 3] = rng.uniform(0.05, 0.3, size=(2, 3))
    return Robot("random", tuple(links), convention=convention, base=base, tool=tool)


def _every_parameter(robot):
    """Every parameter name of every group but the sag: offsets (revolute and prismatic), a, d, tool, base."""
    names = parameter_names(robot, ("joint_offsets", "link_lengths", "base_offset"))
    assert {nm[:2] for nm in names} >= {"of", "a[", "d[", "to", "ba"}
    return names


@pytest.mark.parametrize("convention", [Convention.STANDARD, Convention.MODIFIED])
def test_derivatives_match_central_differences(convention, rng):
    for _ in range(3):
        robot = _random_robot(rng, convention)
        names = _every_parameter(robot)
        x = np.array([_nominal(robot, nm) for nm in names]) + rng.normal(0.0, 0.05, size=len(names))
        q = rng.uniform(-1.0, 1.0, size=(7, robot.n))
        positions, D = _position_derivatives(robot, names, x, q)
        assert D.shape == (7, 3, len(names))
        assert np.allclose(positions, fk_position(apply_parameters(robot, names, x), q), rtol=0, atol=1e-13)
        h = 1e-6
        for k, name in enumerate(names):  # of a robot built with each parameter moved (no frames, no derivatives)
            step = np.zeros(len(names))
            step[k] = h
            central = (fk_position(apply_parameters(robot, names, x + step), q)
                       - fk_position(apply_parameters(robot, names, x - step), q)) / (2 * h)
            scale = np.abs(central).max()
            assert scale > 0.01, name
            assert np.allclose(D[..., k], central, rtol=0, atol=1e-7 * scale), name


def _reference_fit(robot, names, q, measured):
    """The unweighted fit, its per-pose standard errors and leave-one-out residuals with scipy's 3-point differences."""
    from scipy.optimize import least_squares

    nominal = np.array([_nominal(robot, nm) for nm in names])

    def residuals(x, rows):
        r = fk_position(apply_parameters(robot, names, x), q[rows]) - measured[rows]
        return r[~np.isnan(r)]

    rows = np.arange(len(q))
    options = dict(jac="3-point", x_scale="jac", method="trf")
    sol = least_squares(residuals, nominal, args=(rows,), **options)
    pose_of = np.broadcast_to(rows[:, None], measured.shape)[~np.isnan(measured)]
    std = np.sqrt(np.diag(_covariance(sol.jac, sol.fun, pose_of, "per_pose")[0]))
    loo = np.full_like(measured, np.nan)
    for i in rows:
        s = least_squares(residuals, sol.x, args=(rows[rows != i],), **options)
        loo[i] = fk_position(apply_parameters(robot, names, s.x), q[i]) - measured[i]
    return sol.x, std, loo


def _same_fit(result, reference):
    fitted, std, loo = reference
    assert np.all(np.abs(result.fitted - fitted) <= np.maximum(1e-7, 1e-3 * std))
    assert np.allclose(result.std_error, std, rtol=1e-4, atol=0)
    assert np.array_equal(np.isnan(result.loo_residuals), np.isnan(loo))
    assert np.nanmax(np.abs(result.loo_residuals - loo)) <= 1e-7


def test_seed_tables_fit_matches_finite_differences():
    arm = Robot.load("arduino_arm_3dof")
    result = calibrate(arm, measurement_file("seed000_fk_tables1-3.csv"), params=("joint_offsets", "link_lengths"))
    _same_fit(result, _reference_fit(arm, result.names, result.q, result.measured))


@pytest.mark.parametrize("convention", [Convention.STANDARD, Convention.MODIFIED])
def test_fit_of_every_group_matches_finite_differences(convention, rng):
    robot = _random_robot(rng, convention, n=4)
    q = rng.uniform(-1.5, 1.5, size=(30, robot.n))
    names = ()  # the parameters of every group that these poses tell apart (some pairs move the tool alike)
    candidates = sorted(_every_parameter(robot), key=lambda nm: ("tool" not in nm and "base" not in nm) + (nm[0] != "d"))
    for name in candidates:
        x = [_nominal(robot, nm) for nm in names + (name,)]
        sv = np.linalg.svd(_position_derivatives(robot, names + (name,), x, q)[1].reshape(-1, len(x)), compute_uv=False)
        names += (name,) if sv[-1] > 1e-6 * sv[0] else ()
    assert {nm[:2] for nm in names} >= {"of", "a[", "d[", "to", "ba"}
    truth = apply_parameters(robot, names, [_nominal(robot, nm) + rng.normal(0.0, 0.01) for nm in names])
    measured = fk_position(truth, q) + rng.normal(0.0, 5e-4, size=(30, 3))
    measured[[3, 11], [0, 2]] = np.nan  # axes not measured
    result = calibrate(robot, (q, measured), params=names)
    assert result.rms_after < result.rms_before
    _same_fit(result, _reference_fit(robot, names, q, measured))
