"""Far, NaN, infinite and misshapen IK targets: a ``LabkitError`` or a clean answer, never a raw error.

A hypothesis sweep over ``ik``, ``ik_all`` and ``ik_numeric`` on arms of every target kind (position,
planar, x y z pitch, x y z pitch roll, x y z yaw, pose) and of the numeric solver: each call raises a
:class:`~labkit.exceptions.LabkitError` or returns finite joint values (``ik``: inside the limits).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from labkit.exceptions import LabkitError, ShapeError
from labkit.kinematics import ik, ik_all, ik_numeric, target_components, target_kind
from labkit.robot import Robot

ARMS = ("arduino_arm_3dof", "planar3r_seed004", "openmanipulator_x", "so101", "puma560", "scara_standard",
        "rpp_seed002", "puma_wrist_seed002")
BAD = st.one_of(
    st.sampled_from([math.nan, math.inf, -math.inf, 1e308, -1e308, 1e200, 1e10, -1e9 - 1.0, 5e-324, 0.0]),
    st.floats(allow_nan=True, allow_infinity=True),
)
FAIR = st.floats(-1.0, 1.0)


def _robot(name):
    path = Path(__file__).parent / "robots" / f"{name}.toml"
    return Robot.load(path if path.exists() else name)


def _targets(kind):
    """Targets of ``kind`` with bad entries, or of a wrong shape, or not numbers at all."""
    size = len(target_components(kind))
    right = st.lists(st.one_of(BAD, FAIR), min_size=size, max_size=size)
    if kind == "pose":
        right = st.lists(st.one_of(BAD, FAIR), min_size=3, max_size=3).map(_pose)
    wrong = st.one_of(st.lists(FAIR, min_size=0, max_size=7).filter(lambda v: len(v) != size),
                      st.lists(st.lists(BAD, min_size=2, max_size=5), min_size=1, max_size=3),
                      st.sampled_from(["x", None, {}, [[1.0], [2.0, 3.0]], np.zeros((2, 4, 4))]))
    return st.one_of(right, right.map(lambda t: [t, t]), wrong)


def _pose(p):
    T = np.eye(4)
    T[:3, 3] = p
    return T


def _check(robot, call):
    try:
        out = call()
    except LabkitError:
        return
    q = np.asarray(getattr(out, "q", out))
    assert np.isfinite(q).all()
    return out


@pytest.mark.parametrize("name", ARMS)
def test_bad_targets_are_labkit_errors_or_clean_answers(name):
    robot = _robot(name)
    kind = target_kind(robot)
    numeric_only = name == "puma_wrist_seed002"  # ik would run its numeric restarts on every far target

    @settings(max_examples=40, deadline=None, derandomize=True)
    @given(_targets(kind))
    def sweep(target):
        res = _check(robot, lambda: ik_numeric(robot, target, restarts=1, max_iter=10))
        if res is not None:
            assert res.success.dtype == bool
        if numeric_only:
            return
        sols = _check(robot, lambda: ik_all(robot, target))
        if sols is not None:
            assert np.isfinite(sols.distance).all()
        q = _check(robot, lambda: ik(robot, target))
        if q is not None:
            assert robot.within_limits(q).all()

    sweep()


@pytest.mark.parametrize("name", ["arduino_arm_3dof", "planar3r_seed004", "puma560", "scara_standard"])
def test_a_target_at_1e308_is_a_shape_error_naming_the_bound(name):
    robot = _robot(name)
    kind = target_kind(robot)
    target = _pose([1e308, 0.0, 0.0]) if kind == "pose" else [1e308] + [0.0] * (len(target_components(kind)) - 1)
    for f in (ik, ik_all, ik_numeric):
        with pytest.raises(ShapeError, match=r"within \+-1e\+09 \(m, rad\), got 1e\+308"):
            f(robot, target)
