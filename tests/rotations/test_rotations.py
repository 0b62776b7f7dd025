"""Tests of labkit.rotations (seed 002 problem 1 numbers, round trips, validity)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from labkit.exceptions import ShapeError
from labkit.rotations import (
    EulerConvention,
    check_rotation,
    compose_fixed_frame,
    compose_moving_frame,
    euler_from_matrix,
    is_rotation,
    matrix_from_euler,
    matrix_from_rpy,
    nearest_rotation,
    rotation_about,
    rotation_x,
    rotation_y,
    rotation_z,
    rpy_from_matrix,
    wrap_angle,
)
from labkit.exceptions import RotationMatrixError

SEED_1A = np.array([[0.8660, 0, 0.5], [0.3536, 0.7071, -0.6124], [-0.3536, 0.7071, 0.6124]])
SEED_1B_MATRIX = np.array([[0.866, -0.5, 0], [0.5, 0.866, 0], [0, 0, 1]])
SEED_1B_FROM_ANGLES = np.array([[0.8660, 0.3536, 0.3536], [0, 0.7071, -0.7071], [-0.5, 0.6124, 0.6124]])


# -- elementary rotations ------------------------------------------------------

@pytest.mark.parametrize("fn, axis", [(rotation_x, 0), (rotation_y, 1), (rotation_z, 2)])
def test_elementary_rotation_fixes_its_axis_and_is_proper(fn, axis, rng):
    angles = rng.uniform(-np.pi, np.pi, size=(4, 5))
    R = fn(angles)
    assert R.shape == (4, 5, 3, 3)
    e = np.zeros(3)
    e[axis] = 1
    assert np.allclose(R @ e, e)
    assert np.all(is_rotation(R, tol=1e-12))


def test_right_hand_rule():
    assert np.allclose(rotation_z(np.pi / 2) @ [1, 0, 0], [0, 1, 0])
    assert np.allclose(rotation_x(np.pi / 2) @ [0, 1, 0], [0, 0, 1])
    assert np.allclose(rotation_y(np.pi / 2) @ [0, 0, 1], [1, 0, 0])


def test_rotation_about_names_and_rejects_bad_axis():
    assert np.allclose(rotation_about("Z", 0.3), rotation_z(0.3))
    with pytest.raises(ValueError, match="'x', 'y' or 'z', got 'w'"):
        rotation_about("w", 0.3)


# -- compositions: seed 002 problem 1(a) ---------------------------------------

def test_seed002_problem1a_moving_frame_x_then_y():
    """beta = pi/4 about x, then alpha = pi/6 about the new y: R = Rx(beta) Ry(alpha)."""
    R = compose_moving_frame("xy", [np.pi / 4, np.pi / 6])
    assert np.allclose(R, SEED_1A, atol=5e-5)


def test_seed002_problem1a_fixed_frame_y_then_x():
    """The same matrix read in the fixed frame: about y by alpha first, then about fixed x by beta."""
    R = compose_fixed_frame(("y", "x"), [np.pi / 6, np.pi / 4])
    assert np.allclose(R, SEED_1A, atol=5e-5)


def test_seed002_problem1a_other_readings_differ():
    """The other two readings give the matrix of problem 1(b) instead (the seed's remark on order)."""
    assert not np.allclose(compose_fixed_frame("xy", [np.pi / 4, np.pi / 6]), SEED_1A, atol=1e-3)
    assert np.allclose(compose_moving_frame("yx", [np.pi / 6, np.pi / 4]), SEED_1B_FROM_ANGLES, atol=5e-5)


def test_moving_equals_reversed_fixed(rng):
    seqs = ["x", "yxz", "zyz", "xxy", "zyxzy"]
    for seq in seqs:
        angles = rng.uniform(-np.pi, np.pi, size=(7, len(seq)))
        Rm = compose_moving_frame(seq, angles)
        Rf = compose_fixed_frame(seq[::-1], angles[:, ::-1])
        assert Rm.shape == (7, 3, 3)
        assert np.allclose(Rm, Rf, atol=1e-12)


def test_composition_shape_errors():
    with pytest.raises(ShapeError, match=r"shape \(\.\.\., 3\), got \(2,\)"):
        compose_moving_frame("yxz", [0.1, 0.2])
    with pytest.raises(ValueError, match="non-empty"):
        compose_fixed_frame("", [])
    with pytest.raises(ShapeError, match="finite"):
        compose_fixed_frame("xy", [np.nan, 0.0])


# -- Euler / RPY: seed 002 problem 1(b) ----------------------------------------

def test_seed002_problem1b_matrix_to_xyz_fixed_two_solutions():
    e = euler_from_matrix(SEED_1B_MATRIX, "xyz_fixed")
    assert not e.gimbal_lock
    assert np.allclose(np.degrees(e.first), [0, 0, 30], atol=0.01)
    # seed prints (-180, -180, -150) deg: the same angles; labkit wraps to (-180, 180]
    seed_second = np.radians([-180, -180, -150])
    assert np.allclose(np.degrees(e.second), [180, 180, -150], atol=0.01)
    assert np.allclose(wrap_angle(seed_second), e.second, atol=1e-3)
    for sol in (e.first, e.second, seed_second):
        assert np.allclose(matrix_from_euler(sol, "xyz_fixed"), SEED_1B_MATRIX, atol=1e-3)


def test_seed002_problem1b_xyz_fixed_to_matrix():
    angles = [np.pi / 4, np.pi / 6, 0.0]  # gamma (x), beta (y), alpha (z)
    for R in (matrix_from_euler(angles, "xyz_fixed"), matrix_from_rpy(angles), matrix_from_euler(angles, "rpy")):
        assert np.allclose(R, SEED_1B_FROM_ANGLES, atol=5e-5)
    # the seed's closed form R = Rz(alpha) Ry(beta) Rx(gamma)
    assert np.allclose(matrix_from_euler(angles[::-1], "ZYX"), SEED_1B_FROM_ANGLES, atol=5e-5)


CONVENTIONS = ["xyz_fixed", "ZYX", "ZYZ"]


@pytest.mark.parametrize("conv", CONVENTIONS)
def test_both_solutions_round_trip_batched(conv, rng):
    angles = rng.uniform(-np.pi, np.pi, size=(50, 3))
    R = matrix_from_euler(angles, conv)
    e = euler_from_matrix(R, conv)
    assert e.solutions.shape == (50, 2, 3)
    assert e.gimbal_lock.shape == (50,)
    assert not e.gimbal_lock.any()
    for k in range(2):
        assert np.allclose(matrix_from_euler(e.solutions[:, k], conv), R, atol=1e-10)
    # the two solutions really are different triples
    assert np.all(np.abs(wrap_angle(e.first - e.second)).max(axis=-1) > 1e-6)
    # the original triple is one of the two
    d = np.abs(wrap_angle(e.solutions - angles[:, None, :])).max(axis=-1).min(axis=-1)
    assert np.all(d < 1e-9)
    assert np.all(np.abs(e.solutions) <= np.pi + 1e-15)


@settings(max_examples=200, deadline=None)
@given(
    angles=arrays(float, 3, elements=st.floats(-np.pi, np.pi)),
    conv=st.sampled_from(CONVENTIONS),
)
def test_round_trip_hypothesis(angles, conv):
    R = matrix_from_euler(angles, conv)
    e = euler_from_matrix(R, conv)
    for k in range(2):
        assert np.allclose(matrix_from_euler(e.solutions[k], conv), R, atol=1e-9)


@pytest.mark.parametrize(
    "conv, beta",
    [("xyz_fixed", np.pi / 2), ("xyz_fixed", -np.pi / 2), ("ZYX", np.pi / 2), ("ZYX", -np.pi / 2),
     ("ZYZ", 0.0), ("ZYZ", np.pi)],
)
def test_gimbal_lock_flag_and_representative(conv, beta):
    if conv == "xyz_fixed":
        angles = np.array([0.7, beta, -0.4])
    else:
        angles = np.array([-0.4, beta, 0.7])
    R = matrix_from_euler(angles, conv)
    e = euler_from_matrix(R, conv)
    assert bool(e.gimbal_lock)
    assert np.allclose(e.first, e.second)
    assert np.allclose(matrix_from_euler(e.first, conv), R, atol=1e-12)
    assert "gimbal lock" in e.family
    # the representative sets the third angle to 0, as scipy: alpha (yaw) for xyz_fixed, gamma for ZYX / ZYZ
    assert e.first[2] == 0.0


def test_gimbal_lock_tolerance_on_rounded_matrix():
    R = matrix_from_euler([0.3, np.pi / 2 - 2e-6, 0.0], "xyz_fixed")  # cos(beta) = 2e-6
    assert not euler_from_matrix(R, "xyz_fixed").gimbal_lock
    assert euler_from_matrix(R, "xyz_fixed", tol=1e-5).gimbal_lock


def test_euler_convention_errors_list_valid_values():
    # 'xyx' (extrinsic proper Euler) is valid since all 24 conventions are; 'xyy' repeats an axis
    for bad in ("xyy", "XYx", "xyz_moved", "abc"):
        with pytest.raises(ValueError, match=rf"'XYZ'.*'ZYZ'.*'xyz'.*'zyz'.*_moving.*_fixed.*'rpy'.*got '{bad}'"):
            matrix_from_euler([0, 0, 0], bad)
    assert euler_from_matrix(np.eye(3), EulerConvention.ZYZ).convention is EulerConvention.ZYZ
    with pytest.raises(ShapeError, match=r"\(\.\.\., 3, 3\), got \(3, 2\)"):
        euler_from_matrix(np.zeros((3, 2)), "ZYZ")


def test_rpy_from_matrix_matches_first_solution(rng):
    rpy = rng.uniform(-1.5, 1.5, size=(10, 3))
    assert np.allclose(rpy_from_matrix(matrix_from_rpy(rpy)), rpy, atol=1e-12)


def test_wrap_angle():
    assert np.allclose(wrap_angle([3 * np.pi, -np.pi, np.pi, 0.5 - 2 * np.pi]), [np.pi, np.pi, np.pi, 0.5])


def test_wrap_angle_lands_in_the_half_open_interval_at_every_edge():
    # floats next to odd multiples of pi (where a turn is decided by the last bits), and random ones
    edges = np.array([k * np.pi for k in range(-41, 42, 2)] + [-np.pi, np.pi])
    near = np.concatenate([edges + d * np.spacing(edges) for d in range(-4, 5)] + [
        np.random.default_rng(3).uniform(-1e3, 1e3, size=20000)])
    w = wrap_angle(near)
    assert np.all((w > -np.pi) & (w <= np.pi))
    assert w.tobytes() == np.array([wrap_angle(float(x)) for x in near]).tobytes()  # one formula, arrays and floats
    inside = near[(near > -np.pi) & (near <= np.pi)]
    assert inside.size > 10 and wrap_angle(inside).tobytes() == inside.tobytes()  # already wrapped: unchanged
    assert wrap_angle(float(np.nextafter(-np.pi, 0.0))) == float(np.nextafter(-np.pi, 0.0))  # (was pi + 1 ulp)
    # the wrapped angle is the angle less whole turns (to rounding)
    assert np.allclose(np.cos(w), np.cos(near), atol=1e-12) and np.allclose(np.sin(w), np.sin(near), atol=1e-12)


def test_wrap_angle_of_one_float_is_the_array_result():
    # the float path returns most angles as they are; near -pi and outside (-pi, pi] it applies the formula
    rng = np.random.default_rng(3)
    near = [np.pi, -np.pi, 0.0, -0.0, -3.14, np.nextafter(-3.14, 0.0), np.nextafter(-np.pi, 0.0),
            np.nextafter(np.pi, 0.0), np.nextafter(np.pi, 4.0), 3 * np.pi, -7.5, 1e300, -1e-300]
    values = np.concatenate([near, rng.uniform(-10.0, 10.0, 2000), rng.uniform(-np.pi, np.pi, 2000)])
    one = np.array([wrap_angle(float(v)) for v in values])
    assert all(type(wrap_angle(float(v))) is float for v in near)
    assert np.array_equal(one, wrap_angle(values))  # (-0.0 stays -0.0 on a float, as before)
    assert wrap_angle(-np.pi) == np.pi and wrap_angle(np.pi) == np.pi and wrap_angle(-3.0) == -3.0


# -- validity and re-orthonormalisation ----------------------------------------

def test_is_rotation_batched(rng):
    R = matrix_from_euler(rng.uniform(-3, 3, size=(6, 3)), "ZYZ")
    bad = R.copy()
    bad[1] *= 1.01
    bad[2, :, 0] *= -1  # reflection
    bad[3, 0, 0] = np.nan
    ok = is_rotation(bad)
    assert ok.tolist() == [True, False, False, False, True, True]


def test_check_rotation_messages():
    with pytest.raises(RotationMatrixError, match=r"orthonormal.*nearest_rotation"):
        check_rotation(np.diag([1.0, 1.0, 1.1]))
    with pytest.raises(RotationMatrixError, match=r"det R = -1.*reflection"):
        check_rotation(np.diag([1.0, 1.0, -1.0]))
    R = np.stack([np.eye(3), np.eye(3) * 2])
    with pytest.raises(RotationMatrixError, match=r"batch index \(1,\)"):
        check_rotation(R)
    with pytest.raises(ValueError, match="orthonormal"):
        check_rotation(SEED_1B_MATRIX)  # rounded to 3 decimals: off by ~1e-4 > 1e-6
    assert check_rotation(SEED_1B_MATRIX, tol=1e-3).shape == (3, 3)
    with pytest.raises(ShapeError):
        check_rotation(np.eye(4))


def test_nearest_rotation_repairs_rounded_and_noisy(rng):
    R0 = matrix_from_euler(rng.uniform(-3, 3, size=(20, 3)), "ZYX")
    noisy = R0 + rng.normal(scale=1e-3, size=R0.shape)
    R = nearest_rotation(noisy)
    assert np.all(is_rotation(R, tol=1e-12))
    assert np.abs(R - R0).max() < 5e-3
    # an exact rotation is a fixed point
    assert np.allclose(nearest_rotation(R0), R0, atol=1e-12)
    # seed 002 1(b): the rounded matrix is re-orthonormalised to a 30 deg rotation about z
    Rs = nearest_rotation(SEED_1B_MATRIX)
    assert np.allclose(np.degrees(euler_from_matrix(Rs, "xyz_fixed").first), [0, 0, 30], atol=1e-3)


def test_nearest_rotation_of_a_reflection_is_proper():
    R = nearest_rotation(np.diag([1.0, 1.0, -1.0]))
    assert np.isclose(np.linalg.det(R), 1.0)


def test_euler_angles_table(rng):
    R = matrix_from_euler(rng.uniform(-1, 1, size=(4, 3)), "ZYZ")
    df = euler_from_matrix(R, "ZYZ").to_dataframe(degrees=False)
    assert df.shape == (8, 4)
    assert list(df.columns) == ["alpha (z) [rad]", "beta (y') [rad]", "gamma (z'') [rad]", "gimbal_lock"]
    e = euler_from_matrix(R, "ZYZ")
    assert np.allclose(df.loc[(2, 2)].values[:3].astype(float), e.second[2])
    locked = euler_from_matrix(rotation_y(np.pi / 2), "xyz_fixed").to_dataframe()
    assert locked["gimbal_lock"].all() and len(locked) == 2


@pytest.mark.parametrize("conv", CONVENTIONS)
def test_near_gimbal_lock_measured_matrices_reconstruct_to_rounding(conv, rng):
    """Next to (not at) gimbal lock, slightly perturbed matrices still give exact angle triples."""
    angles = rng.uniform(-3, 3, size=(500, 3))
    eps = rng.choice([1e-5, 1e-7, 1e-8, 3e-9], size=500)
    if conv == "ZYZ":
        angles[:, 1] = np.where(rng.random(500) < 0.5, eps, np.pi - eps)
    else:
        angles[:, 1] = np.where(rng.random(500) < 0.5, np.pi / 2 - eps, -np.pi / 2 + eps)
    R = nearest_rotation(matrix_from_euler(angles, conv) + rng.normal(scale=1e-13, size=(500, 3, 3)))
    e = euler_from_matrix(R, conv)
    assert not e.gimbal_lock.any()
    assert np.abs(matrix_from_euler(e.solutions, conv) - R[:, None]).max() < 1e-13
