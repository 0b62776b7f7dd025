"""All 24 Euler conventions (labkit.rotations._euler): round trips of both solutions, gimbal lock, scipy agreement."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from labkit.exceptions import OptionError
from labkit.rotations import EulerConvention, euler_from_matrix, matrix_from_euler, nearest_rotation, wrap_angle

ALL = list(EulerConvention)


def _proper(conv):
    return conv.axes[0] == conv.axes[2]


def test_there_are_24_conventions_and_scipy_names_resolve():
    assert len(ALL) == 24 and len({c.scipy_name for c in ALL}) == 24
    for conv in ALL:
        if conv.scipy_name in ("zyx", "zyz"):  # labkit's historical intrinsic names win (documented)
            assert euler_from_matrix(np.eye(3), conv.scipy_name).convention is EulerConvention[conv.name[:3]]
        else:
            assert euler_from_matrix(np.eye(3), conv.scipy_name).convention is conv
        assert euler_from_matrix(np.eye(3), conv.value).convention is conv
    # historical aliases keep their meaning; explicit _fixed / _moving spellings
    aliases = {"rpy": "XYZ_FIXED", "xyz_fixed": "XYZ_FIXED", "xyz": "XYZ_FIXED", "zyx": "ZYX", "zyz": "ZYZ",
               "ZYX": "ZYX", "zyx_fixed": "ZYX_FIXED", "zyz_fixed": "ZYZ_FIXED", "zyx_moving": "ZYX",
               "xzx": "XZX_FIXED", "XZX": "XZX"}
    for name, member in aliases.items():
        assert euler_from_matrix(np.eye(3), name).convention is EulerConvention[member], name
    with pytest.raises(OptionError, match=r"got 'zyy'"):
        euler_from_matrix(np.eye(3), "zyy")


@pytest.mark.parametrize("conv", ALL, ids=lambda c: c.value)
def test_matrix_and_angles_agree_with_scipy(conv, rng):
    angles = rng.uniform(-np.pi, np.pi, size=(200, 3))
    angles[:, 1] = rng.uniform(0.05, np.pi - 0.05, 200) if _proper(conv) else rng.uniform(-1.5, 1.5, 200)
    R = matrix_from_euler(angles, conv)
    ref = Rotation.from_euler(conv.scipy_name, angles)
    assert np.abs(R - ref.as_matrix()).max() < 1e-14
    e = euler_from_matrix(R, conv)
    assert not e.gimbal_lock.any()
    theirs = Rotation.from_matrix(R).as_euler(conv.scipy_name)
    # scipy's single solution is labkit's first (same range of the middle angle)
    assert np.abs(wrap_angle(e.first - theirs)).max() < 1e-9
    # and the original triple is one of the two
    d = np.abs(wrap_angle(e.solutions - angles[:, None, :])).max(axis=-1).min(axis=-1)
    assert d.max() < 1e-9
    for k in range(2):
        assert np.abs(matrix_from_euler(e.solutions[:, k], conv) - R).max() < 1e-13
    assert np.all(np.abs(wrap_angle(e.first - e.second)).max(axis=-1) > 1e-6)


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
    alpha = e.solutions[..., 2] if conv.extrinsic else e.solutions[..., 0]  # the representative's alpha = 0
    assert np.all(alpha[e.gimbal_lock] == 0.0)
    assert np.allclose(e.first[e.gimbal_lock], e.second[e.gimbal_lock])
    assert "gimbal lock" in e.family


@pytest.mark.parametrize("conv", ALL, ids=lambda c: c.value)
def test_gimbal_lock_family_text_is_right(conv):
    """At lock, R depends only on the combination of alpha and gamma that ``family`` names."""
    import re

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
