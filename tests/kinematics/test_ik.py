"""Tests of labkit.kinematics IK: seed numbers, FK o IK round trips on every branch, errors, numeric IK."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from labkit.robot import Robot
from labkit.exceptions import JointLimitError, ShapeError, UnreachableError
from labkit.kinematics import IKResult, IKSolutions, Solver, ik, ik_all, ik_numeric, solver_for, target_kind
from labkit.kinematics import fk, fk_position

ANALYTIC = {
    "arduino_arm_3dof": "yaw_pitch_pitch",
    "planar3r_seed003": "planar_3r",
    "planar3r_seed003_135": "planar_3r",
    "planar3r_seed004": "planar_3r",
    "puma560": "spherical_wrist",
    "puma600_seed002": "spherical_wrist",
}


@pytest.fixture(scope="module")
def arm():
    return Robot.load("arduino_arm_3dof")


@pytest.fixture(scope="module")
def puma():
    return Robot.load("puma560")


def _target_of(robot, q):
    """The IK target that FK of q reaches, in the robot's target kind."""
    kind = target_kind(robot)
    T = fk(robot, q)
    if kind == "pose":
        return T
    if kind == "planar":
        return np.concatenate([T[..., :2, 3], np.arctan2(T[..., 1, 0], T[..., 0, 0])[..., None]], axis=-1)
    return T[..., :3, 3]


def _wrapped(d):
    return np.abs(np.remainder(d + np.pi, 2 * np.pi) - np.pi)


# -- solver detection -----------------------------------------------------------------

@pytest.mark.parametrize(
    "name, kind, solver",
    [(n, {"yaw_pitch_pitch": "position", "planar_3r": "planar", "spherical_wrist": "pose"}[s], s)
     for n, s in ANALYTIC.items()]
    + [("rpp_seed002", "position", "cylindrical"), ("puma_wrist_seed002", "position", "numeric")],
)
def test_target_kind_and_automatic_solver(name, kind, solver):
    robot = Robot.load(name)
    assert target_kind(robot) == kind
    assert solver_for(robot) is Solver(solver)


def test_forced_solver_errors(arm):
    with pytest.raises(ValueError, match="unknown IK solver 'fast'.*'auto', 'planar_2r', 'planar_3r'"):
        ik_all(arm, [0.1, 0.1, -0.1], solver="fast")
    with pytest.raises(ValueError, match="'spherical_wrist' does not fit.*6 revolute.*automatic choice is 'yaw_pitch_pitch'"):
        ik_all(arm, [0.1, 0.1, -0.1], solver="spherical_wrist")
    with pytest.raises(ValueError, match="'planar_3r' does not fit.*parallel to world \\+z"):
        ik(arm, [0.1, 0.1, -0.1], solver=Solver.PLANAR_3R)


def test_detection_survives_an_offset_base_and_a_rotated_tool():
    """The geometry is read from FK at q = 0, so base/tool transforms and offsets are fine."""
    from labkit.rotations import matrix_from_rpy

    puma = Robot.load("puma560")
    base = np.eye(4)
    base[:3, :3] = matrix_from_rpy([0.3, -0.2, 1.0])
    base[:3, 3] = [0.5, -0.2, 0.1]
    tool = np.eye(4)
    tool[:3, :3] = matrix_from_rpy([0.1, 0.2, 0.3])
    tool[:3, 3] = [0.02, 0.0, 0.1]
    robot = puma.replace(base=base, tool=tool).with_link(1, theta=0.3)
    assert solver_for(robot) is Solver.SPHERICAL_WRIST
    q = np.random.default_rng(5).uniform(-1, 1, (200, 6))
    T = fk(robot, q)
    sols = ik_all(robot, T)
    assert sols.reachable.all()
    assert np.abs(fk(robot, sols.q) - T[:, None]).max() < 1e-9


# -- seed 000: the Arduino arm --------------------------------------------------------

# table 4 of seed 000: target [m] -> calculated joint angles [deg] (elbow up)
SEED000_TABLE4 = [
    ((0.10, 0.10, -0.10), (45, 114, 109)),
    ((0.15, 0.00, -0.10), (0, 108, 105)),
    ((-0.10, 0.10, 0.00), (135, 98, 129)),
    ((0.20, 0.10, -0.05), (27, 60, 71)),
    ((-0.08, 0.05, -0.10), (148, 147, 131)),
]


@pytest.mark.parametrize("target, published", SEED000_TABLE4)
def test_seed000_table4_calculated_columns(arm, target, published):
    q = ik(arm, target, branch="elbow_up")
    assert np.array_equal(np.round(np.degrees(q)), published)
    assert np.allclose(fk_position(arm, q), target, atol=1e-12)
    # elbow up is the first valid branch, hence the default
    assert np.allclose(ik(arm, target), q)


def test_seed000_table4_row5_discrepancy(arm):
    """Row 5, (-0.10, 0.25, -0.01) -> (-45, 105, 82) deg, disagrees with the model.

    theta1 = atan2(0.25, -0.10) = 111.8 deg (not -45), and FK of the published
    angles lands 0.2 m away from the target. The test pins the model's answer.
    """
    target = (-0.10, 0.25, -0.01)
    q = ik(arm, target, branch="elbow_up")
    assert math.isclose(math.degrees(q[0]), math.degrees(math.atan2(0.25, -0.10)), abs_tol=1e-9)
    assert np.allclose(np.degrees(q), [111.80, 16.65, 22.05], atol=0.01)
    published = np.radians([-45.0, 105.0, 82.0])
    assert np.linalg.norm(fk_position(arm, published) - target) > 0.1
    assert np.allclose(fk_position(arm, q), target, atol=1e-12)


def _seed000_formulas(X, Y, Z, L1=0.094, L2=0.180):
    """Seed 000 section III.1, written as published (alpha, beta, k)."""
    d2 = X * X + Y * Y + Z * Z
    alpha = np.arctan2(-Z, np.sqrt(X * X + Y * Y))
    beta = np.arccos((L1**2 + d2 - L2**2) / (2 * L1 * np.sqrt(d2)))
    k = np.arccos((L1**2 + L2**2 - d2) / (2 * L1 * L2))
    return np.arctan2(Y, X), alpha, beta, k


def test_seed000_elbow_up_formula_and_corrected_elbow_down(arm, rng):
    q_true = rng.uniform([0.05, 0.1, 0.1], [3.0, 3.0, 3.0], size=(500, 3))
    p = fk_position(arm, q_true)
    X, Y, Z = p.T
    q1, alpha, beta, k = _seed000_formulas(X, Y, Z)
    sols = ik_all(arm, p)
    up = np.stack([q1, alpha + beta, np.pi - k], axis=-1)
    assert np.allclose(sols["elbow_up"], up, atol=1e-9)
    # the seed's elbow-down (alpha - beta, pi - k "stays the same") does not reach the target ...
    seed_down = np.stack([q1, alpha - beta, np.pi - k], axis=-1)
    miss = np.linalg.norm(fk_position(arm, seed_down) - p, axis=-1)
    assert np.all(miss > 1e-3)
    # ... the correct elbow-down has q3 = -(pi - k), and it is labkit's elbow_down
    down = np.stack([q1, alpha - beta, -(np.pi - k)], axis=-1)
    assert np.allclose(fk_position(arm, down), p, atol=1e-12)
    assert np.allclose(_wrapped(sols["elbow_down"] - down), 0.0, atol=1e-9)


def test_arduino_back_branches_are_q1_plus_pi_with_mirrored_shoulder(arm, rng):
    p = fk_position(arm, rng.uniform(0.2, 2.9, size=(100, 3)))
    sols = ik_all(arm, p)
    up, back_up = sols["elbow_up"], sols["back_elbow_up"]
    assert np.allclose(_wrapped(back_up[:, 0] - up[:, 0] - np.pi), 0.0, atol=1e-12)
    assert np.allclose(_wrapped(back_up[:, 1] - (np.pi - up[:, 1])), 0.0, atol=1e-9)
    assert np.allclose(back_up[:, 2], -up[:, 2], atol=1e-9)


def test_arduino_leaning_back_needs_the_back_branch(arm):
    """A pose leaning backwards (q2 > 90 deg) puts the gripper behind the base:
    the seed's theta1 = atan2(Y, X) is then 180 deg off and outside the servo
    range; only the back branch (theta1 + 180 deg, q2 -> 180 - q2, q3 -> -q3) is valid."""
    q = np.radians([100.0, 150.0, 60.0])
    p = fk_position(arm, q)
    sols = ik_all(arm, p)
    assert sols.valid.tolist() == [False, False, False, True]
    assert np.allclose(sols["back_elbow_down"], q, atol=1e-12)
    assert np.allclose(ik(arm, p), q, atol=1e-12)


# -- FK o IK round trips on every analytic solver and branch ---------------------------------

@pytest.mark.parametrize("name", sorted(ANALYTIC))
def test_round_trip_every_branch(name):
    robot = Robot.load(name)
    rng = np.random.default_rng(2024)
    q = rng.uniform(-np.pi, np.pi, size=(2000, robot.n))
    target = _target_of(robot, q)
    sols = ik_all(robot, target)
    assert sols.solver == ANALYTIC[name]
    m = len(sols.branches)
    assert sols.q.shape == (2000, m, robot.n) and sols.reachable.all()
    assert np.all(sols.distance == 0.0)
    reached = _target_of(robot, sols.q)
    if target_kind(robot) == "planar":
        err = np.abs(reached[..., :2] - target[:, None, :2]).max()
        err = max(err, _wrapped(reached[..., 2] - target[:, None, 2]).max())
    elif target_kind(robot) == "pose":
        err = np.abs(reached - target[:, None]).max()
    else:
        err = np.abs(reached - target[:, None]).max()
    assert err < 1e-9
    # the configuration we started from is one of the branches
    found = _wrapped(sols.q - q[:, None]).max(axis=-1).min(axis=-1)
    assert np.quantile(found, 0.999) < 1e-6
    # solutions are pairwise distinct in general position
    assert len(set(sols.branches)) == m
    # valid = reachable and inside the joint limits
    assert np.array_equal(sols.valid, sols.reachable & robot.within_limits(sols.q))


def test_elbow_branches_are_geometric(arm, puma, rng):
    """Elbow up puts the elbow on the "up" side of the shoulder -> wrist-centre line."""
    from labkit.kinematics import fk_frames

    def height_above_line(F):
        # shoulder (frame 1 origin), elbow (frame 2 origin, on axis 3), wrist centre (frame 4 origin),
        # projected onto the arm plane (normal: joint 2 axis = z1)
        n = F[:, 1, :3, 2]
        S = F[:, 1, :3, 3]
        E, W = (X - n * ((X - S) * n).sum(-1, keepdims=True) for X in (F[:, 2, :3, 3], F[:, 4, :3, 3]))
        t = ((E - S) * (W - S)).sum(-1) / ((W - S) ** 2).sum(-1)
        return E[:, 2] - (S[:, 2] + t * (W - S)[:, 2])

    q = rng.uniform(-1.5, 1.5, size=(300, 6))
    sols = ik_all(puma, fk(puma, q))
    assert np.all(height_above_line(fk_frames(puma, sols["right_up_noflip"])) > -1e-9)
    assert np.all(height_above_line(fk_frames(puma, sols["left_up_flip"])) > -1e-9)
    assert np.all(height_above_line(fk_frames(puma, sols["right_down_noflip"])) < 1e-9)
    # the Arduino arm's frame 0 z points down (servos keep the elbow at z <= 0): "up" is -z0
    p = fk_position(arm, rng.uniform(0.3, 2.8, size=(200, 3)))
    s = ik_all(arm, p)
    F = fk_frames(arm, s["elbow_up"])
    elbow, tip = F[:, 3, :3, 3], p
    radial = tip[:, :2] / np.hypot(tip[:, 0], tip[:, 1])[:, None]
    r_e, r_t = (elbow[:, :2] * radial).sum(-1), (tip[:, :2] * radial).sum(-1)
    # elbow clockwise from the shoulder -> tip direction in the (r, z) plane, i.e. towards -z0
    assert np.all(r_t * elbow[:, 2] - tip[:, 2] * r_e < 1e-12)


def test_puma_wrist_singularity_is_finite_and_exact(puma):
    q = np.array([[0.3, 0.4, -0.5, 0.7, 0.0, -0.2], [0.0, 1.57, -1.57, 0.0, 0.0, 0.0]])
    T = fk(puma, q)
    sols = ik_all(puma, T)
    assert np.isfinite(sols.q).all() and sols.reachable.all()
    assert np.abs(fk(puma, sols.q) - T[:, None]).max() < 1e-9


@pytest.mark.parametrize("q5", [0.0, 1e-12, -1e-10, 1e-9, 1e-7, np.pi - 1e-9])
def test_near_wrist_singularity_keeps_full_precision(q5):
    """Near q5 = 0 or pi the wrist angles come from tiny vectors: no cancellation allowed."""
    from labkit.rotations import matrix_from_rpy

    rng = np.random.default_rng(31)
    for name in ("puma560", "puma600_seed002"):
        robot = Robot.load(name)
        base = np.eye(4)
        base[:3, :3] = matrix_from_rpy([0.3, -0.2, 1.0])  # axes not aligned with x, y, z
        robot = robot.replace(base=base)
        q = rng.uniform(-np.pi, np.pi, size=(300, 6))
        q[:, 4] = q5
        T = fk(robot, q)
        sols = ik_all(robot, T)
        assert np.abs(fk(robot, sols.q) - T[:, None]).max() < 1e-12


@settings(max_examples=150, deadline=None)
@given(st.tuples(*[st.floats(-0.35, 0.35, allow_nan=False) for _ in range(3)]))
def test_arduino_any_target_round_trips_or_reports_distance(target):
    arm = Robot.load("arduino_arm_3dof")
    sols = ik_all(arm, target)
    assert np.isfinite(sols.q).all()
    r = np.linalg.norm(target)
    if sols.reachable.any():
        assert sols.reachable.all()
        assert np.abs(fk_position(arm, sols.q) - np.asarray(target)).max() < 1e-9
        assert float(sols.distance) == 0.0
    else:
        expected = max(r - 0.274, 0.086 - r)
        assert math.isclose(float(sols.distance), expected, abs_tol=1e-12)


# -- seed 002: PUMA 600 -------------------------------------------------------------

SEED002_T = np.array(
    [
        [0.2522, 0.1044, 0.9620, 719.3029],
        [-0.7874, -0.5558, 0.2667, 602.9285],
        [0.5625, -0.8248, -0.0580, 541.2981],
        [0, 0, 0, 1],
    ]
)


def test_seed002_puma600_pi_over_6_round_trip():
    puma600 = Robot.load("puma600_seed002")
    T = fk(puma600, np.full(6, np.pi / 6))
    published = SEED002_T.copy()
    published[:3, 3] /= 1000.0
    assert np.allclose(T, published, atol=5e-5)
    sols = ik_all(puma600, T)
    assert sols.q.shape == (8, 6) and sols.valid.all()
    hit = np.all(np.abs(sols.q - np.pi / 6) < 1e-9, axis=1)
    assert hit.sum() == 1 and sols.branches[int(np.argmax(hit))] == "right_up_noflip"
    # the seed's two answers for theta1: 0.5236 and -2.1156 rad
    assert np.allclose(sorted(set(np.round(sols.q[:, 0], 4))), [-2.1156, 0.5236])
    # and the published (4-decimal) matrix itself, re-orthonormalised, solves to pi/6 within rounding
    U, _, Vt = np.linalg.svd(published[:3, :3])
    published[:3, :3] = U @ Vt
    q = ik(puma600, published, branch="right_up_noflip")
    assert np.allclose(q, np.pi / 6, atol=2e-4)


def test_rtb_style_branch_aliases(puma):
    T = fk(puma, [0.2, 0.6, -0.4, 0.3, 0.5, 0.1])
    assert np.allclose(ik(puma, T, branch="lun"), ik(puma, T, branch="left_up_noflip"))
    with pytest.raises(ValueError, match="unknown branch 'lux'; expected one of right_up_noflip"):
        ik(puma, T, branch="lux")


# -- planar 3R (seeds 003 and 004) -------------------------------------------------------

def test_planar_seed004_elbow_minus_alias():
    arm = Robot.load("planar3r_seed004")
    target = [0.30, 0.20, np.pi / 4]
    q = ik(arm, target, branch="elbow_minus")
    assert q[1] < 0
    assert np.allclose(q, ik(arm, target, branch="elbow_up"))
    assert ik(arm, target, branch="elbow_plus")[1] > 0
    T = fk(arm, q)
    assert np.allclose([T[0, 3], T[1, 3], math.atan2(T[1, 0], T[0, 0])], target, atol=1e-12)
    # seed 004 A.2: theta2 = +-atan2(sqrt(1 - c^2), c), c = (d13^2 - L1^2 - L2^2) / (2 L1 L2)
    x3, y3 = 0.30 - 0.12 * math.cos(np.pi / 4), 0.20 - 0.12 * math.sin(np.pi / 4)
    c = (x3 * x3 + y3 * y3 - 0.2**2 - 0.15**2) / (2 * 0.2 * 0.15)
    assert math.isclose(q[1], -math.atan2(math.sqrt(1 - c * c), c), abs_tol=1e-12)


def test_planar_seed003_limits_filter_branches():
    arm = Robot.load("planar3r_seed003")  # limits +-90 deg
    q = np.radians([10.0, 60.0, 70.0])
    target = _target_of(arm, q)
    sols = ik_all(arm, target)
    # elbow up reaches the same (x, y, phi) with q = (70, -60, 130) deg: q3 outside +-90
    assert np.allclose(np.degrees(sols["elbow_up"]), [70.0, -60.0, 130.0])
    assert sols.valid.tolist() == [False, True]
    assert np.allclose(sols["elbow_down"], q, atol=1e-12)
    assert np.allclose(ik(arm, target), q, atol=1e-12)


def test_planar_unreachable_distance():
    arm = Robot.load("planar3r_seed004")
    # wrist point 0.5 m from the base: 0.15 m beyond L1 + L2 = 0.35 m
    target = [0.5 + 0.12, 0.0, 0.0]
    with pytest.raises(UnreachableError, match=r"out of reach by 0\.15 m \(150\.0 mm\)") as info:
        ik(arm, target)
    assert math.isclose(info.value.distance, 0.15, abs_tol=1e-12)
    assert info.value.index is None


# -- errors -----------------------------------------------------------------------------

def test_unreachable_batch_reports_first_bad_index(arm):
    targets = np.array([[[0.1, 0.1, -0.1], [0.1, 0.0, -0.1]], [[0.2, 0.0, -0.1], [0.3, 0.0, 0.0]]])
    with pytest.raises(UnreachableError, match=r"target \(1, 1\).*out of reach by 0\.026 m") as info:
        ik(arm, targets)
    assert info.value.index == (1, 1)
    assert math.isclose(info.value.distance, 0.3 - 0.274, abs_tol=1e-12)
    # ik_all reports instead of raising, and never returns NaN
    sols = ik_all(arm, targets)
    assert sols.reachable.shape == (2, 2, 4) and sols.q.shape == (2, 2, 4, 3)
    assert not sols.reachable[1, 1].any() and sols.reachable[0, 0].all()
    assert np.isfinite(sols.q).all()
    assert np.isclose(sols.distance[1, 1], 0.026) and sols.distance[0, 0] == 0.0


def test_too_close_is_unreachable_too(arm):
    with pytest.raises(UnreachableError, match=r"out of reach by 0\.076 m") as info:
        ik(arm, [0.0, 0.0, -0.01])
    assert math.isclose(info.value.distance, 0.086 - 0.01, abs_tol=1e-12)


def test_reachable_only_outside_limits_names_the_joint(arm):
    with pytest.raises(JointLimitError, match=r"reachable only outside the joint limits: elbow_up: joint 1 \(base_yaw\) = -45") as info:
        ik(arm, [0.1, -0.1, -0.1])
    assert info.value.joint == 0
    with pytest.raises(JointLimitError, match=r"elbow_down: joint 2 \(shoulder_pitch\)") as info:
        ik(arm, [0.1, 0.1, -0.1], branch="elbow_down")
    assert info.value.joint == 1


def test_non_finite_and_malformed_targets(arm, puma):
    with pytest.raises(ShapeError, match=r"finite target position.*index \(1,\)"):
        ik(arm, [0.1, np.nan, 0.0])
    with pytest.raises(ValueError, match="finite"):
        ik_all(arm, [[0.1, 0.1, 0.1], [np.inf, 0, 0]])
    with pytest.raises(ShapeError, match=r"expected target position \(x, y, z\) with shape \(\.\.\., 3\), got \(2,\)"):
        ik(arm, [0.1, 0.2])
    with pytest.raises(ShapeError, match=r"shape \(\.\.\., 4, 4\), got \(3,\)"):
        ik(puma, [0.1, 0.2, 0.3])
    T = fk(puma, np.zeros(6))
    T[0, 0] = 2.0
    with pytest.raises(ShapeError, match="rigid transform"):
        ik_all(puma, T)
    with pytest.raises(ShapeError, match=r"finite target pose.*index \(0, 0\)"):
        ik_numeric(puma, np.full((4, 4), np.nan))
    # a few poses are checked on floats, a batch on arrays: the same message, naming the entry
    for count in (2, 40):
        Ts = np.repeat(fk(puma, np.zeros(6))[None], count, axis=0)
        Ts[1, 2, 3] = np.inf
        with pytest.raises(ShapeError, match=r"finite target pose.*index \(1, 2, 3\)"):
            ik_numeric(puma, Ts)


# -- choosing one solution ---------------------------------------------------------------

def test_q_near_picks_the_closest_valid_branch(puma):
    q = np.array([0.2, 0.6, -0.4, 0.3, 0.5, 0.1])
    T = fk(puma, q)
    sols = ik_all(puma, T)
    for k in np.flatnonzero(sols.valid):
        assert np.allclose(ik(puma, T, q_near=sols.q[k] + 0.01), sols.q[k])
    # batched, with one q_near per target
    Ts = np.stack([T, T])
    out = ik(puma, Ts, q_near=np.stack([q, sols.q[np.flatnonzero(sols.valid)[-1]]]))
    assert np.allclose(out[0], q) and np.allclose(out[1], sols.q[np.flatnonzero(sols.valid)[-1]])


def test_batched_shapes(arm):
    q = np.random.default_rng(1).uniform(0.3, 2.8, size=(2, 5, 3))
    p = fk_position(arm, q)
    assert ik(arm, p).shape == (2, 5, 3)
    sols = ik_all(arm, p)
    assert isinstance(sols, IKSolutions) and sols.q.shape == (2, 5, 4, 3) and sols.valid.shape == (2, 5, 4)
    one = ik_all(arm, p[0, 0])
    assert one.q.shape == (4, 3) and one.reachable.shape == (4,)
    df = one.to_dataframe()
    assert list(df.index) == list(one.branches) and df["valid"].tolist() == one.valid.tolist()
    with pytest.raises(KeyError, match="unknown branch 'sideways'"):
        one["sideways"]


def test_angles_are_wrapped_into_the_limits(puma):
    # q2 limits [-45, 225] deg: a solution at q2 = 200 deg is reported as 200, not -160
    q = np.radians([10, 200, -60, 20, 40, 30])
    sols = ik_all(puma, fk(puma, q))
    k = int(np.argmin(np.abs(sols.q - q).max(axis=1)))
    assert np.allclose(sols.q[k], q, atol=1e-9) and sols.valid[k]
    # angles that fit either way come back in [-pi, pi]
    assert np.all(np.abs(sols.q[:, [0, 3, 4, 5]]) <= np.pi + 1e-12)


# -- numeric IK -------------------------------------------------------------------------

def test_numeric_acceptance_10000_puma560_targets(puma):
    """Issue 2 acceptance: 100 % success, residual < 1e-9 (the rate, >= 4000 targets/s, is
    printed by benchmarks/bench_kinematics.py: speed is a benchmark figure, not a timed test)."""
    rng = np.random.default_rng(560)
    lim = puma.joint_limits
    q = rng.uniform(lim[:, 0], lim[:, 1], size=(10_000, 6))
    T = fk(puma, q)
    res = ik_numeric(puma, T)
    assert isinstance(res, IKResult)
    assert res.success.all()
    assert res.residual.max() < 1e-9
    assert puma.within_limits(res.q).all()
    assert np.abs(fk(puma, res.q) - T).max() < 1e-9


@pytest.mark.parametrize("name", ["puma_wrist_seed002"])
def test_numeric_position_ik_for_non_analytic_robots(name):
    robot = Robot.load(name)
    rng = np.random.default_rng(7)
    lim = np.clip(robot.joint_limits, -3, 3)
    q = rng.uniform(lim[:, 0], lim[:, 1], size=(300, robot.n))
    p = fk_position(robot, q)
    res = ik_numeric(robot, p)
    assert res.success.all() and res.residual.max() < 1e-9
    assert np.abs(fk_position(robot, res.q) - p).max() < 1e-9
    # ik() falls back to the numeric solver and respects the limits
    q1 = ik(robot, p[:5])
    assert robot.within_limits(q1).all() and np.allclose(fk_position(robot, q1), p[:5], atol=1e-9)
    sols = ik_all(robot, p[:3])
    assert sols.branches == ("numeric",) and sols.valid.all() and sols.solver == "numeric"


def test_numeric_failure_is_reported_not_nan():
    rpp = Robot.load("rpp_seed002")
    far = [10.0, 0.0, 0.5]
    res = ik_numeric(rpp, far, restarts=2)
    assert not res.success and np.isfinite(res.q).all() and res.residual > 1.0
    assert rpp.within_limits(res.q)
    with pytest.raises(UnreachableError, match="numeric IK found no solution") as info:
        ik(rpp, far, solver="numeric")
    assert info.value.distance > 1.0


def test_numeric_masks_and_kinds(puma):
    rng = np.random.default_rng(3)
    lim = puma.joint_limits
    q = rng.uniform(lim[:, 0], lim[:, 1], size=(200, 6))
    T = fk(puma, q)
    # position only on a 6R arm
    res = ik_numeric(puma, T[:, :3, 3], kind="position")
    assert res.success.all() and np.abs(fk_position(puma, res.q) - T[:, :3, 3]).max() < 1e-9
    # position + yaw only (mask over x, y, z, rx, ry, rz)
    res = ik_numeric(puma, T, mask=[1, 1, 1, 0, 0, 1])
    assert res.success.all()
    assert np.abs(fk_position(puma, res.q) - T[:, :3, 3]).max() < 1e-9
    with pytest.raises(ShapeError, match="mask with 6 entries"):
        ik_numeric(puma, T, mask=[1, 1, 1])
    with pytest.raises(ValueError, match="unknown target kind 'orientation'"):
        ik_numeric(puma, T, kind="orientation")
    # planar numeric agrees with the analytic planar solver
    arm = Robot.load("planar3r_seed004")
    tgt = _target_of(arm, rng.uniform(-2, 2, size=(100, 3)))
    res = ik_numeric(arm, tgt)
    assert res.success.all()
    assert np.all(_wrapped(ik(arm, tgt, q_near=res.q) - res.q) < 1e-7)
    # planar position only (mask over x, y, phi): phi is ignored
    res = ik_numeric(arm, np.c_[tgt[:, :2], np.zeros(100)], mask=[1, 1, 0])
    assert res.success.all() and np.abs(fk(arm, res.q)[:, :2, 3] - tgt[:, :2]).max() < 1e-9
    # q0 seeds the iteration: starting at the answer converges at once
    res = ik_numeric(puma, T[:3], q0=q[:3])
    assert np.all(res.iterations <= 1) and np.allclose(res.q, q[:3])
    assert len(res.to_dataframe()) == 3


def test_forcing_numeric_on_an_analytic_robot(arm):
    sols = ik_all(arm, [0.1, 0.1, -0.1], solver="numeric")
    assert sols.branches == ("numeric",) and sols.valid.all()
    assert np.allclose(fk_position(arm, sols.q[0]), [0.1, 0.1, -0.1], atol=1e-9)


# -- generality of the structure detection ----------------------------------------------

def _craig_puma560():
    """PUMA 560 in Craig's modified DH (Introduction to Robotics, table 3.4)."""
    from labkit.robot import Link

    d90 = np.pi / 2
    rows = [(0, 0, 0), (-d90, 0, 0), (0, 0.4318, 0.15005), (-d90, 0.0203, 0.4318), (d90, 0, 0), (-d90, 0, 0)]
    links = tuple(Link(a=a, alpha=al, d=d, limits=(-np.pi, np.pi)) for al, a, d in rows)
    return Robot(name="puma560_craig", links=links, convention="modified")


def _round_trip_error(robot, q):
    target = _target_of(robot, q)
    sols = ik_all(robot, target)
    assert sols.reachable.all()
    reached = _target_of(robot, sols.q)
    if target_kind(robot) == "planar":
        return max(np.abs(reached[..., :2] - target[:, None, :2]).max(),
                   _wrapped(reached[..., 2] - target[:, None, 2]).max())
    return np.abs(reached - target[:, None]).max()


def test_modified_dh_puma_uses_the_spherical_wrist_solver():
    robot = _craig_puma560()
    assert solver_for(robot) is Solver.SPHERICAL_WRIST
    q = np.random.default_rng(11).uniform(-np.pi, np.pi, size=(500, 6))
    assert _round_trip_error(robot, q) < 1e-9


def test_planar_solver_with_offsets_and_a_moved_base():
    from labkit.rotations import rotation_z

    arm = Robot.load("planar3r_seed003")
    base = np.eye(4)
    base[:3, :3] = rotation_z(0.7)
    base[:3, 3] = [0.1, -0.2, 0.05]
    robot = arm.replace(base=base).with_link(1, theta=0.3).with_link(0, a=0.02)
    assert solver_for(robot) is Solver.PLANAR_3R
    q = np.random.default_rng(12).uniform(-np.pi, np.pi, size=(500, 3))
    assert _round_trip_error(robot, q) < 1e-9


def test_yaw_pitch_pitch_with_a_lateral_offset():
    arm = Robot.load("arduino_arm_3dof").with_link(2, d=0.02)  # elbow axis shifted sideways
    assert solver_for(arm) is Solver.YAW_PITCH_PITCH
    q = np.random.default_rng(13).uniform(-np.pi, np.pi, size=(500, 3))
    assert _round_trip_error(arm, q) < 1e-9
    # inside the offset cylinder around the base axis nothing is reachable
    with pytest.raises(UnreachableError, match="out of reach"):
        ik(arm, [0.005, 0.0, -0.1])


# -- the `labkit ik` command ------------------------------------------------------------

def test_cli_ik_prints_every_branch(capsys):
    from labkit.cli import main

    assert main(["ik", "arduino_arm_3dof", "100", "100", "-100", "--mm", "--deg"]) == 0
    out = capsys.readouterr().out
    assert "solver yaw_pitch_pitch" in out
    row = next(line for line in out.splitlines() if line.strip().startswith("elbow_up"))
    assert row.split()[1:4] == ["45.0000", "113.8648", "109.3922"] and row.split()[-1] == "ok"
    assert "outside joint limits" in out
    assert main(["ik", "rpp_seed002", "0.5", "0.5", "1.0"]) == 0
    out = capsys.readouterr().out
    assert "d2 [m]" in out and "solver cylindrical" in out and "front" in out
    assert main(["ik", "puma560", "0.5", "0.1", "0.3", "0", "90", "0", "--deg"]) == 0
    assert "right_up_flip" in capsys.readouterr().out


def test_cli_ik_errors(capsys):
    from labkit.cli import main

    assert main(["ik", "arduino_arm_3dof", "1", "1", "1"]) == 1
    assert "out of reach by 1.458 m" in capsys.readouterr().err
    assert main(["ik", "puma560", "0.5", "0.1"]) == 2
    assert "this arm takes x y z roll pitch yaw (pose targets), got 2 values: z roll pitch yaw missing" in \
        capsys.readouterr().err


@pytest.mark.parametrize("robot, values, message", [
    ("openmanipulator_x", ["200", "0", "100"], "this arm takes x y z pitch (position_pitch targets), got 3 values: "
                                               "pitch missing"),
    ("openmanipulator_x", ["200", "0", "100", "0", "0", "0"], "this arm takes x y z pitch (position_pitch targets), "
                                                              "got 6 values"),
    ("so101", ["200", "0", "100", "-90"], "this arm takes x y z pitch roll (position_pitch_roll targets), got 4 "
                                          "values: roll missing"),
    ("al5d", ["200", "0"], "this arm takes x y z pitch roll (position_pitch_roll targets), got 2 values: z pitch "
                           "roll missing"),
])
def test_cli_ik_says_which_target_the_arm_takes(capsys, robot, values, message):
    from labkit.cli import main

    assert main(["ik", robot, *values, "--mm", "--deg"]) == 2
    err = capsys.readouterr().err
    assert message in err and "inf" not in err


def test_cli_ik_solves_pitch_and_roll_targets_and_never_says_inf(capsys):
    from labkit.cli import main

    assert main(["ik", "openmanipulator_x", "200", "0", "100", "-60", "--mm", "--deg"]) == 0
    out = capsys.readouterr().out
    assert "solver yaw_pitch_pitch_pitch, target x y z pitch" in out
    rows = {line.split()[0]: line.split() for line in out.splitlines() if "elbow" in line.split()[0]}
    assert set(rows) == {"elbow_up", "elbow_down", "back_elbow_up", "back_elbow_down"}
    q = np.radians([float(v) for v in rows["elbow_up"][1:5]])
    T = fk(Robot.load("openmanipulator_x"), q)
    assert np.allclose(T[:3, 3], [0.2, 0.0, 0.1], atol=1e-6)  # printed to 1e-4 deg
    assert np.degrees(np.arcsin(T[2, 0])) == pytest.approx(-60.0, abs=1e-3)  # pitch: the approach (tool x) 60 deg down
    assert main(["ik", "al5d", "150", "100", "50", "-60", "20", "--mm", "--deg"]) == 0
    out = capsys.readouterr().out
    row = next(line.split() for line in out.splitlines() if line.strip().startswith("elbow_up"))
    assert row[5] == "20.0000"  # wrist rotate = roll (its axis points towards the tool)
    assert main(["ik", "openmanipulator_x", "900", "0", "100", "0", "--mm", "--deg"]) == 1
    err = capsys.readouterr().err
    assert "out of reach by" in err and "mm" in err and "inf" not in err


def test_boundary_configurations_stay_reachable_and_exact(arm, puma):
    """Arm fully stretched or folded (cosine law at +-1), and the PUMA's ready pose."""
    for q in [(0.5, 1.0, 0.0), (0.5, 1.0, np.pi), (0.0, 0.0, 0.0)]:
        p = fk_position(arm, q)
        sols = ik_all(arm, p)
        assert sols.reachable.all() and float(sols.distance) == 0.0
        assert np.abs(fk_position(arm, sols.q) - p).max() < 1e-12
    for q in [(0.0, np.pi / 2, -np.pi / 2, 0.0, 0.0, 0.0), np.zeros(6)]:
        T = fk(puma, q)
        sols = ik_all(puma, T)
        assert sols.reachable.all() and np.abs(fk(puma, sols.q) - T).max() < 1e-12


@settings(max_examples=100, deadline=None)
@given(st.lists(st.floats(-np.pi, np.pi, allow_nan=False), min_size=6, max_size=6))
def test_puma600_any_configuration_is_among_the_8_solutions(q):
    puma600 = Robot.load("puma600_seed002")
    q = np.array(q)
    T = fk(puma600, q)
    sols = ik_all(puma600, T)
    assert sols.reachable.all() and np.isfinite(sols.q).all()
    assert np.abs(fk(puma600, sols.q) - T).max() < 1e-9
    if abs(math.sin(q[4])) > 1e-6:  # away from the wrist singularity q5 = 0 (q4, q6 not unique there)
        assert _wrapped(sols.q - q).max(axis=-1).min() < 1e-6


@pytest.mark.parametrize("name", sorted(ANALYTIC) + ["irb140", "kr5", "ur5"])
def test_flipped_joints_keep_closed_form_ik_exact_and_branches_geometric(name):
    """Flipping joints (their limits mirrored) negates those columns of every branch, name for name."""
    from dataclasses import replace

    robot = Robot.load(name)
    flips = [j % 2 == 0 for j in range(robot.n)]  # joints 1, 3, 5 flipped
    flipped = robot.replace(links=tuple(
        replace(lk, flip=True, limits=(-lk.limits[1], -lk.limits[0])) if f else lk
        for lk, f in zip(robot.links, flips)))
    sign = np.where(flips, -1.0, 1.0)
    rng = np.random.default_rng(77)
    lim = robot.joint_limits
    q = rng.uniform(lim[:, 0], lim[:, 1], size=(300, robot.n))
    target = _target_of(robot, q)
    assert np.abs(_target_of(flipped, q * sign) - target).max() < 1e-12
    plain, mirrored = ik_all(robot, target), ik_all(flipped, target)
    assert mirrored.solver == plain.solver and mirrored.branches == plain.branches
    assert np.array_equal(mirrored.reachable, plain.reachable)
    assert np.array_equal(mirrored.valid, plain.valid)
    assert _wrapped(mirrored.q - plain.q * sign).max() < 1e-9
    reached = _target_of(flipped, mirrored.q)
    if target_kind(robot) == "planar":
        reached[..., 2] = target[:, None, 2] + np.remainder(reached[..., 2] - target[:, None, 2] + np.pi, 2 * np.pi) - np.pi
    miss = np.abs(reached - target[:, None]).reshape(len(q), len(plain.branches), -1).max(axis=-1)
    assert miss[mirrored.reachable].max() < 1e-9  # (shoulder-offset and UR arms: not every branch reaches)
    # the configuration we started from (in the flipped robot's terms) is among the branches
    found = _wrapped(mirrored.q - (q * sign)[:, None]).max(axis=-1).min(axis=-1)
    assert np.quantile(found, 0.99) < 1e-6


def test_ik_is_the_function_and_no_package_hides_behind_it():
    """``labkit.kinematics.ik`` is the public function; no subpackage of that name is shadowed by it (or
    cited through it), and no module of ``labkit.kinematics`` shares a name with a public attribute."""
    import importlib
    import pkgutil
    from pathlib import Path

    import labkit.kinematics as kin

    assert callable(kin.ik) and kin.ik.__module__ == "labkit.kinematics._ik"
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("labkit.kinematics.ik")
    modules = {info.name for info in pkgutil.iter_modules(kin.__path__)}
    assert not modules & set(kin.__all__), modules & set(kin.__all__)
    root = Path(kin.__file__).resolve().parents[1]
    cited = [str(p) for p in root.rglob("*.py") if "labkit.kinematics.ik." in p.read_text(encoding="utf-8")]
    assert not cited, cited
