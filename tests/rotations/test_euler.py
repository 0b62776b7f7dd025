"""All 24 Euler conventions (labkit.rotations._euler): scipy's names and agreement with scipy,
round trips of both solutions, gimbal lock."""

import itertools
import re
import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from labkit.exceptions import LabkitError, OptionError
from labkit.rotations import (
    EulerConvention,
    compose_fixed_frame,
    compose_moving_frame,
    euler_from_matrix,
    matrix_from_euler,
    matrix_from_rpy,
    nearest_rotation,
    wrap_angle,
)

ALL = list(EulerConvention)
# the 12 axis sequences, built here (not taken from labkit): no axis twice in a row
SEQUENCES = ["".join(p) for p in itertools.product("xyz", repeat=3) if p[0] != p[1] and p[1] != p[2]]
# scipy's 24 names: upper case = intrinsic (moving axes), lower case = extrinsic (fixed axes)
SCIPY_NAMES = [q.upper() for q in SEQUENCES] + SEQUENCES


def _proper(conv):
    return conv.axes[0] == conv.axes[2]


def _angles(rng, name, n=200):
    """Random triples away from gimbal lock (middle angle in scipy's range)."""
    angles = rng.uniform(-np.pi, np.pi, size=(n, 3))
    proper = name[0].lower() == name[2].lower()
    angles[:, 1] = rng.uniform(0.05, np.pi - 0.05, n) if proper else rng.uniform(-1.5, 1.5, n)
    return angles


def _scipy_as_euler(R, name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # scipy's "Gimbal lock detected"
        return Rotation.from_matrix(R).as_euler(name)


def test_there_are_24_conventions_and_every_scipy_name_is_its_own():
    assert len(SEQUENCES) == 12 and len(ALL) == 24
    assert sorted(c.scipy_name for c in ALL) == sorted(SCIPY_NAMES)
    for conv in ALL:
        assert EulerConvention(conv.scipy_name) is conv
        assert EulerConvention(conv.value) is conv
        assert euler_from_matrix(np.eye(3), conv.scipy_name).convention is conv
        assert conv.extrinsic == conv.scipy_name.islower()


@pytest.mark.parametrize("name", SCIPY_NAMES)
def test_scipy_names_give_scipys_matrices(name, rng):
    angles = rng.uniform(-np.pi, np.pi, size=(200, 3))
    ref = Rotation.from_euler(name, angles).as_matrix()
    assert np.abs(matrix_from_euler(angles, name) - ref).max() < 1e-14
    compose = compose_moving_frame if name.isupper() else compose_fixed_frame
    assert np.abs(compose(name.lower(), angles) - ref).max() < 1e-14


@pytest.mark.parametrize("seq", ["zyx", "zyz"])
def test_lower_case_zyx_and_zyz_are_extrinsic_like_scipy(seq, rng):
    """Once labkit's intrinsic names: now scipy's fixed-axis sets (the intrinsic ones are upper case)."""
    angles = _angles(rng, seq, 50)
    fixed = matrix_from_euler(angles, seq)
    assert np.abs(fixed - Rotation.from_euler(seq, angles).as_matrix()).max() < 1e-14
    assert np.abs(fixed - matrix_from_euler(angles, seq + "_fixed")).max() == 0.0
    moving = matrix_from_euler(angles, seq.upper())
    assert np.abs(moving - Rotation.from_euler(seq.upper(), angles).as_matrix()).max() < 1e-14
    assert np.abs(fixed - moving).max() > 0.1  # really different readings
    assert euler_from_matrix(np.eye(3), seq).convention is EulerConvention[seq.upper() + "_FIXED"]


@pytest.mark.parametrize("seq", SEQUENCES)
def test_moving_and_fixed_names_equal_their_scipy_case_twins(seq, rng):
    angles = _angles(rng, seq, 50)
    for explicit, twin in ((seq + "_moving", seq.upper()), (seq + "_fixed", seq)):
        assert EulerConvention(explicit) is EulerConvention(twin)
        R = matrix_from_euler(angles, explicit)
        assert np.array_equal(R, matrix_from_euler(angles, twin))
        assert np.abs(R - Rotation.from_euler(twin, angles).as_matrix()).max() < 1e-14
        e = euler_from_matrix(R, explicit)
        assert e.convention is EulerConvention(twin)
        assert np.array_equal(e.solutions, euler_from_matrix(R, twin).solutions)
    assert EulerConvention[seq.upper() + "_MOVING"] is EulerConvention(seq.upper())


def test_rpy_is_scipys_fixed_axis_xyz(rng):
    angles = rng.uniform(-np.pi, np.pi, size=(20, 3))
    ref = Rotation.from_euler("xyz", angles).as_matrix()
    for R in (matrix_from_euler(angles, "rpy"), matrix_from_rpy(angles)):
        assert np.abs(R - ref).max() < 1e-14
    assert EulerConvention("rpy") is EulerConvention.XYZ_FIXED is EulerConvention("xyz")


@pytest.mark.parametrize(
    "bad", ["zyy", "xyy", "XYx", "Zyx", "ZYX_fixed", "zyx_MOVING", "XYZ_FIXED", "xyz_moved", "rpy_fixed", "RPY",
            "abc", "", "zyxz", 3, None])
def test_bad_names_raise_option_error_listing_the_valid_ones(bad):
    for call in (lambda: matrix_from_euler([0.0, 0.0, 0.0], bad), lambda: euler_from_matrix(np.eye(3), bad),
                 lambda: EulerConvention(bad)):
        with pytest.raises(OptionError) as info:
            call()
        msg = str(info.value)
        assert isinstance(info.value, LabkitError) and isinstance(info.value, ValueError)
        assert msg.endswith("got " + repr(bad)), msg
        listed = set(re.findall(r"'([A-Za-z_<>]+)'", msg[: msg.rindex("got ")]))
        assert set(SCIPY_NAMES) <= listed, sorted(set(SCIPY_NAMES) - listed)
        assert {"<axes>_moving", "<axes>_fixed", "rpy"} <= listed


@pytest.mark.parametrize("conv", ALL, ids=lambda c: c.scipy_name)
def test_angles_from_matrix_both_solutions_first_is_scipys(conv, rng):
    angles = _angles(rng, conv.scipy_name)
    R = Rotation.from_euler(conv.scipy_name, angles).as_matrix()
    e = euler_from_matrix(R, conv.scipy_name)
    assert e.solutions.shape == (200, 2, 3)
    assert not e.gimbal_lock.any()
    # scipy's single solution is labkit's first (same range of the middle angle)
    assert np.abs(wrap_angle(e.first - _scipy_as_euler(R, conv.scipy_name))).max() < 1e-9
    # and the original triple is one of the two
    d = np.abs(wrap_angle(e.solutions - angles[:, None, :])).max(axis=-1).min(axis=-1)
    assert d.max() < 1e-9
    for k in range(2):
        assert np.abs(Rotation.from_euler(conv.scipy_name, e.solutions[:, k]).as_matrix() - R).max() < 1e-13
    assert np.all(np.abs(wrap_angle(e.first - e.second)).max(axis=-1) > 1e-6)


def _near_lock(conv, rng, eps):
    n = len(eps)
    angles = rng.uniform(-np.pi, np.pi, size=(n, 3))
    side = rng.random(n) < 0.5
    if _proper(conv):
        angles[:, 1] = np.where(side, eps, np.pi - eps)
    else:
        angles[:, 1] = np.where(side, np.pi / 2 - eps, -np.pi / 2 + eps)
    return Rotation.from_euler(conv.scipy_name, angles).as_matrix()


@pytest.mark.parametrize("conv", ALL, ids=lambda c: c.scipy_name)
def test_gimbal_lock_first_solution_against_scipy(conv, rng):
    """At gimbal lock both give the representative with the third angle 0; just next to it
    (labkit's tol 1e-9 < distance < scipy's 1e-7) scipy still declares lock and rebuilds R only to
    about that distance, labkit returns the exact pair; farther away they agree again."""
    name = conv.scipy_name
    at = _near_lock(conv, rng, np.zeros(50))
    e = euler_from_matrix(at, name)
    assert e.gimbal_lock.all()
    ours, theirs = e.first, _scipy_as_euler(at, name)
    assert np.all(ours[:, 2] == 0.0)
    assert np.abs(wrap_angle(ours - theirs)).max() < 1e-9
    # between the two tolerances: labkit rebuilds R to rounding, scipy does not
    eps = rng.choice([1e-8, 3e-8, 8e-8], size=200)
    near = _near_lock(conv, rng, eps)
    e = euler_from_matrix(near, name)
    assert not e.gimbal_lock.any()
    for k in range(2):
        assert np.abs(matrix_from_euler(e.solutions[:, k], name) - near).max() < 1e-13
    scipy_err = np.abs(Rotation.from_euler(name, _scipy_as_euler(near, name)).as_matrix() - near).max(axis=(-1, -2))
    assert np.median(scipy_err) > 1e-9  # about the distance to lock (smaller for some outer angles)
    # beyond scipy's band: the same first solution (to the conditioning ~1e-16 / distance)
    far = _near_lock(conv, rng, rng.choice([3e-7, 1e-6, 1e-4], size=200))
    assert np.abs(wrap_angle(euler_from_matrix(far, name).first - _scipy_as_euler(far, name))).max() < 1e-8


@pytest.mark.parametrize("conv", ALL, ids=lambda c: c.value)
def test_at_and_within_1e_9_of_gimbal_lock_both_solutions_rebuild_r(conv, rng):
    n = 400
    angles = rng.uniform(-np.pi, np.pi, size=(n, 3))
    eps = rng.choice([0.0, 1e-15, 1e-12, 1e-10, 5e-10, 1e-9, 2e-9, 1e-7], size=n)
    side = rng.random(n) < 0.5
    if _proper(conv):
        angles[:, 1] = np.where(side, eps, np.pi - eps)
    else:
        angles[:, 1] = np.where(side, np.pi / 2 - eps, -np.pi / 2 + eps)
    R = nearest_rotation(matrix_from_euler(angles, conv) + rng.normal(scale=1e-14, size=(n, 3, 3)))
    e = euler_from_matrix(R, conv)
    for k in range(2):
        assert np.abs(matrix_from_euler(e.solutions[:, k], conv) - R).max() < 1e-9
    assert e.gimbal_lock[eps == 0].all() and not e.gimbal_lock[eps >= 2e-9].any()
    # the representative zeroes the third angle of the triple (gamma intrinsic, alpha extrinsic), as scipy
    assert np.all(e.solutions[..., 2][e.gimbal_lock] == 0.0)
    assert np.allclose(e.first[e.gimbal_lock], e.second[e.gimbal_lock])
    assert "gimbal lock" in e.family


@pytest.mark.parametrize("conv", ALL, ids=lambda c: c.value)
def test_gimbal_lock_family_text_is_right(conv):
    """At lock, R depends only on the combination of alpha and gamma that ``family`` names."""
    family = euler_from_matrix(np.eye(3), conv).family
    parts = re.findall(r"alpha ([+-]) gamma \(beta = ([^)]*)\)", family)
    assert len(parts) == 2, family
    for sign, beta_text in parts:
        beta = {"0": 0.0, "pi": np.pi, "+pi/2": np.pi / 2, "-pi/2": -np.pi / 2}[beta_text]
        a, g = 0.3, 0.5
        moved_g = g + 0.2 if sign == "-" else g - 0.2
        triples = np.array([[a, beta, g], [a + 0.2, beta, moved_g]])
        if conv.extrinsic:
            triples = triples[:, ::-1]
        R = matrix_from_euler(triples, conv)
        assert np.abs(R[0] - R[1]).max() < 1e-14, (beta, family)


def test_extrinsic_is_reversed_intrinsic(rng):
    angles = rng.uniform(-3, 3, size=(10, 3))
    for seq in ("xyz", "zxz", "yzx"):
        fixed = euler_from_matrix(matrix_from_euler(angles, seq), seq)
        moving = euler_from_matrix(matrix_from_euler(angles[:, ::-1], seq[::-1].upper()), seq[::-1].upper())
        assert np.allclose(fixed.solutions, moving.solutions[..., ::-1], atol=1e-12)


def test_dataframe_columns_name_the_axes():
    assert list(euler_from_matrix(np.eye(3), "YXY").to_dataframe().columns[:3]) == [
        "alpha (y) [deg]", "beta (x') [deg]", "gamma (y'') [deg]"]
    assert list(euler_from_matrix(np.eye(3), "zxy").to_dataframe().columns[:3]) == [
        "gamma (z) [deg]", "beta (x) [deg]", "alpha (y) [deg]"]
