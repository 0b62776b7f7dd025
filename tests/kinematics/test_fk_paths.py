"""The pure-Python small-batch path and the batched kernels of labkit.kinematics agree.

A handful of configurations (``N <= SMALL_BATCH``) runs through
``labkit.kinematics._forward_small``; passing ``out=`` or a bigger batch runs
the array kernels. Random robots of both DH conventions with prismatic joints,
offsets, base and tool transforms; results must agree to 1e-15.
"""

import numpy as np
import pytest

from labkit.exceptions import ShapeError
from labkit.kinematics import fk, fk_jacobian, fk_position, jacobian
from labkit.kinematics._forward import SMALL_BATCH
from labkit.robot import Convention, JointType, Link, Robot
from labkit.rotations import matrix_from_rpy


def _robot(rng, convention, n, moved):
    links = []
    for _ in range(n):
        prismatic = rng.random() < 0.3
        links.append(Link(
            a=rng.choice([0.0, rng.uniform(-0.5, 0.5)]),
            alpha=rng.choice([0.0, np.pi / 2, -np.pi / 2, np.pi, rng.uniform(-np.pi, np.pi)]),
            d=rng.choice([0.0, rng.uniform(-0.5, 0.5)]),
            theta=rng.choice([0.0, rng.uniform(-np.pi, np.pi)]),
            joint_type=JointType.PRISMATIC if prismatic else JointType.REVOLUTE,
            limits=(0.0, 1.0) if prismatic else (-np.pi, np.pi),
        ))
    extra = {}
    if moved:
        for name in ("base", "tool"):
            T = np.eye(4)
            T[:3, :3] = matrix_from_rpy(rng.uniform(-np.pi, np.pi, 3))
            T[:3, 3] = rng.uniform(-0.3, 0.3, 3)
            extra[name] = T
    return Robot(name="random", links=tuple(links), convention=convention, **extra)


ROBOTS = [(conv, n, moved) for conv in Convention for n in (1, 3, 6, 7) for moved in (False, True)]


@pytest.mark.parametrize("convention,n,moved", ROBOTS)
def test_small_path_equals_batched_kernels(convention, n, moved):
    rng = np.random.default_rng(ROBOTS.index((convention, n, moved)))
    for _ in range(4):
        robot = _robot(rng, convention, n, moved)
        q = rng.uniform(-4.0, 4.0, size=(SMALL_BATCH, n))
        point = rng.uniform(-0.2, 0.2, 3)
        # out= forces the batched kernels; a batch of SMALL_BATCH takes the Python path
        T_batched = fk(robot, q, out=np.empty((SMALL_BATCH, 4, 4)))
        np.testing.assert_allclose(fk(robot, q), T_batched, rtol=0, atol=1e-15)
        np.testing.assert_allclose(fk(robot, q[0]), T_batched[0], rtol=0, atol=1e-15)
        p_batched = fk_position(robot, q, point, out=np.empty((SMALL_BATCH, 3)))
        np.testing.assert_allclose(fk_position(robot, q, point), p_batched, rtol=0, atol=1e-15)
        for frame in ("base", "tool"):
            outs = (np.empty((SMALL_BATCH, 4, 4)), np.empty((SMALL_BATCH, 6, n)))
            Tb, Jb = fk_jacobian(robot, q, point=point, frame=frame, out=outs)
            assert Tb is outs[0] and Jb is outs[1]
            Ts, Js = fk_jacobian(robot, q, point=point, frame=frame)
            np.testing.assert_allclose(Ts, Tb, rtol=0, atol=1e-15)
            np.testing.assert_allclose(Js, Jb, rtol=0, atol=1e-15)
            np.testing.assert_allclose(jacobian(robot, q[1], point=point, frame=frame), Jb[1], rtol=0, atol=1e-15)
        # and a big batch (several chunks) agrees with the one-by-one Python path
        qb = rng.uniform(-4.0, 4.0, size=(5000, n))
        Tb, Jb = fk_jacobian(robot, qb)
        for k in (0, 2047, 2048, 4999):
            Ts, Js = fk_jacobian(robot, qb[k])
            np.testing.assert_allclose(Ts, Tb[k], rtol=0, atol=1e-15)
            np.testing.assert_allclose(Js, Jb[k], rtol=0, atol=1e-15)


def test_out_is_written_and_returned():
    puma = Robot.load("puma560")
    q = np.random.default_rng(1).uniform(-1, 1, (7, 3, 6))
    out = np.full((7, 3, 4, 4), np.nan)
    assert fk(puma, q, out=out) is out
    np.testing.assert_array_equal(out, fk(puma, q))
    J = np.full((7, 3, 6, 6), np.nan)
    assert jacobian(puma, q, out=J) is J
    np.testing.assert_array_equal(J, fk_jacobian(puma, q)[1])
    p = np.empty((7, 3, 3))
    assert fk_position(puma, q, out=p) is p
    np.testing.assert_array_equal(p, out[..., :3, 3])


def test_bad_out_is_rejected():
    puma = Robot.load("puma560")
    q = np.zeros((5, 6))
    with pytest.raises(ShapeError, match=r"expected out .* shape \(5, 4, 4\), got ndarray float64 \(4, 4, 4\)"):
        fk(puma, q, out=np.empty((4, 4, 4)))
    with pytest.raises(ShapeError, match="float64"):
        fk(puma, q, out=np.empty((5, 4, 4), dtype=np.float32))
    with pytest.raises(ShapeError, match="C-contiguous"):
        fk(puma, q, out=np.empty((4, 4, 5)).T)
    with pytest.raises(ShapeError, match="pair"):
        fk_jacobian(puma, q, out=np.empty((5, 6, 6)))


def test_small_path_rejects_bad_input_like_the_batched_one():
    arm = Robot.load("arduino_arm_3dof")
    for q in ([0.1, np.nan, 0.0], np.array([[0.1, 0.2, np.inf]])):
        with pytest.raises(ShapeError, match="expected finite q"):
            fk(arm, q)
        with pytest.raises(ShapeError, match="expected finite q"):
            jacobian(arm, q)
    with pytest.raises(ShapeError, match=r"expected q with shape \(\.\.\., 3\), got \(2,\)"):
        fk_position(arm, [0.1, 0.2])
    # integer and list input give the same floats as float arrays
    np.testing.assert_array_equal(fk(arm, [0, 1, 1]), fk(arm, np.array([0.0, 1.0, 1.0])))
