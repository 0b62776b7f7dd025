"""Every closed-form IK family of the registry, on big batches and on a few targets per call.

For each family: FK of every returned branch hits the target, the configuration the target was
made from is among the branches, and the branch set is complete: numeric IK started from many
random configurations finds no solution that is not one of the valid branches.
"""

from pathlib import Path

import numpy as np
import pytest

from labkit.exceptions import OptionError, ShapeError, UnreachableError
from labkit.kinematics import (
    fk, fk_frames, ik, ik_all, ik_numeric, pose_from_position_pitch, solver_for, target_from_pose, target_kind,
)
from labkit.kinematics._ik_solvers import FAMILIES, REDUCED
from labkit.robot import Link, Robot
from labkit.rotations import matrix_from_rpy, wrap_angle


def _planar_2r():
    base = np.eye(4)
    base[:3, :3] = matrix_from_rpy([0.4, 1.0, -0.2])  # plane tilted in the world
    base[:3, 3] = [0.1, 0.2, 0.3]
    links = (Link(a=0.3, d=0.05, limits=(-2.5, 2.5)), Link(a=0.2, d=0.1, theta=0.3, alpha=np.pi, limits=(-2.8, 2.8)))
    return Robot("planar_2r_tilted", links, base=base)


def _arm4():
    """A MeArm / Dobot-like 4-DOF arm: base yaw, shoulder, elbow and wrist pitch, tool 50 mm past the wrist."""
    links = (Link(d=0.1, alpha=np.pi / 2, limits=(-np.pi, np.pi), name="yaw"),
             Link(a=0.15, theta=np.pi / 2, limits=(-np.pi, np.pi), name="shoulder"),
             Link(a=0.15, limits=(-2.8, 2.8), name="elbow"),
             Link(a=0.05, limits=(-2.8, 2.8), name="wrist"))
    return Robot("arm4", links)


def _arm4_noa():
    """arm4 with an n-o-a tool frame: the tool z axis (the approach) along the wrist link, x across the arm's plane."""
    arm = _arm4()
    tool = np.eye(4)
    tool[:3, :3] = matrix_from_rpy([0.0, np.pi / 2, 0.0])
    tool[:3, 3] = [0.02, 0.0, 0.01]
    return Robot("arm4_noa", arm.links, tool=tool)


#: robot-file fixtures of the SCARA, cylindrical and Cartesian families
FIXTURES = Path(__file__).resolve().parent / "robots"


def _fixture(name):
    return lambda: Robot.load(FIXTURES / f"{name}.toml")


def _scara_prrr():
    """A SCARA with its lift first (PRRR), quill down (flipped), on a base tilted in the world."""
    base = np.eye(4)
    base[:3, :3] = matrix_from_rpy([0.3, -0.5, 1.0])
    base[:3, 3] = [0.2, -0.1, 0.4]
    tool = np.eye(4)
    tool[:3, :3] = matrix_from_rpy([0.0, 0.0, 0.7])
    tool[:3, 3] = [0.02, 0.01, 0.05]
    links = (Link(d=0.1, alpha=np.pi, joint_type="prismatic", limits=(-0.2, 0.2), flip=True),
             Link(a=0.35, theta=0.2, limits=(-2.5, 2.5)), Link(a=0.25, limits=(-2.6, 2.6)),
             Link(a=0.03, d=0.02, limits=(-np.pi, np.pi)))
    return Robot("scara_prrr", links, base=base, tool=tool)


def _gantry_pprp():
    """A gantry whose wrist turn sits between its carriages (PPRP, modified DH): the last slide turns with it,
    along the turn's axis, on a base tilted in the world."""
    base = np.eye(4)
    base[:3, :3] = matrix_from_rpy([0.2, 0.4, -0.6])
    tool = np.eye(4)
    tool[:3, :3] = matrix_from_rpy([np.pi, 0.0, 0.3])
    tool[:3, 3] = [0.03, -0.02, 0.06]
    links = (Link(joint_type="prismatic", limits=(0.0, 0.5)),
             Link(alpha=-np.pi / 2, theta=np.pi / 2, joint_type="prismatic", limits=(-0.2, 0.3), flip=True),
             Link(a=0.05, alpha=np.pi / 2, d=0.04, limits=(-3.0, 3.0), flip=True),
             Link(a=0.02, d=0.1, joint_type="prismatic", limits=(0.0, 0.2)))
    return Robot("gantry_pprp", links, convention="modified", base=base, tool=tool)


def _spherical_rrp():
    """An RRP spherical arm (standard DH) whose tool point lies beside the boom and off the shoulder plane."""
    tool = np.eye(4)
    tool[:3, 3] = [0.03, 0.02, 0.05]
    links = (Link(d=0.3, alpha=np.pi / 2, limits=(-3.0, 3.0)),
             Link(d=-0.08, alpha=-np.pi / 2, theta=0.4, limits=(-2.5, 2.5), flip=True),
             Link(a=0.02, theta=np.pi / 2, joint_type="prismatic", limits=(0.2, 0.6)))
    return Robot("spherical_rrp", links, tool=tool)


ROBOTS = {
    "arduino_arm_3dof": (lambda: Robot.load("arduino_arm_3dof"), "yaw_pitch_pitch"),
    "planar3r_seed004": (lambda: Robot.load("planar3r_seed004"), "planar_3r"),
    "puma560": (lambda: Robot.load("puma560"), "spherical_wrist"),
    "arm4": (_arm4, "yaw_pitch_pitch_pitch"),
    "arm4_noa": (_arm4_noa, "yaw_pitch_pitch_pitch"),
    "planar_2r_tilted": (_planar_2r, "planar_2r"),
    "irb140": (lambda: Robot.load("irb140"), "spherical_wrist"),
    "kr5": (lambda: Robot.load("kr5"), "spherical_wrist"),
    "ur5": (lambda: Robot.load("ur5"), "three_parallel"),
    "openmanipulator_x": (lambda: Robot.load("openmanipulator_x"), "yaw_pitch_pitch_pitch"),
    "so101": (lambda: Robot.load("so101"), "yaw_pitch_pitch_pitch_roll"),
    "al5d": (lambda: Robot.load("al5d"), "yaw_pitch_pitch_pitch_roll"),
    "scara_standard": (_fixture("scara_standard"), "scara"),
    "scara_modified": (_fixture("scara_modified"), "scara"),
    "scara_prrr": (_scara_prrr, "scara"),
    "scara_rrp": (_fixture("scara_rrp"), "scara_rrp"),
    "cylindrical_rpp": (_fixture("cylindrical_rpp"), "cylindrical"),
    "rpp_seed002": (lambda: Robot.load("rpp_seed002"), "cylindrical"),
    "gantry_ppp": (_fixture("gantry_ppp"), "cartesian"),
    "gantry_pppr": (_fixture("gantry_pppr"), "cartesian_yaw"),
    "gantry_pprp": (_gantry_pprp, "cartesian_yaw"),
    "spherical_rrp": (_spherical_rrp, "spherical_rrp"),
    "stanford": (_fixture("stanford"), "stanford"),
}


#: targets per call of a "few" (one target is a batch of one, a few a small batch)
FEW = 8
#: (calls, targets per call): many calls of a few targets, one call of a big batch
EVALUATORS = {"few": (60, FEW), "batch": (1, 3000)}


def _target(robot, q):
    return target_from_pose(robot, fk(robot, q))


def _difference(robot, reached, target):
    """``reached - target``, the angles of planar and pitch/roll targets wrapped."""
    d = reached - target
    kind = target_kind(robot)
    if kind == "planar":
        d[..., 2] = wrap_angle(d[..., 2])
    elif kind in REDUCED:
        d[..., 3:] = wrap_angle(d[..., 3:])
    return d


def test_every_family_of_the_registry_is_tested():
    assert {family for _, family in ROBOTS.values()} == {f.name for f in FAMILIES}


def _in_limits(robot, rng, size):
    lim = robot.joint_limits
    return rng.uniform(lim[:, 0], lim[:, 1], size=(size, robot.n))


@pytest.mark.parametrize("evaluator", sorted(EVALUATORS))
@pytest.mark.parametrize("name", ROBOTS)
def test_every_branch_hits_the_target_and_the_start_is_among_them(name, evaluator):
    make, family = ROBOTS[name]
    robot = make()
    assert solver_for(robot).value == family
    rng = np.random.default_rng(5)
    calls, per = EVALUATORS[evaluator]
    q = _in_limits(robot, rng, calls * per)
    target = _target(robot, q)
    parts = [ik_all(robot, target[k * per:(k + 1) * per]) for k in range(calls)]
    assert all(p.solver == family for p in parts)
    sq = np.concatenate([p.q for p in parts])
    reachable = np.concatenate([p.reachable for p in parts])
    valid = np.concatenate([p.valid for p in parts])
    assert np.all(reachable.any(axis=1))
    reached = _target(robot, sq)
    d = _difference(robot, reached, target[:, None])
    err = np.abs(d).reshape(len(q), len(parts[0].branches), -1).max(axis=-1)
    assert err[reachable].max() < 1e-9
    found = np.abs(wrap_angle(sq - q[:, None])).max(axis=-1)
    found = np.where(valid, found, np.inf).min(axis=-1)
    assert found.max() < 1e-7  # 100 % of the in-limit targets: the start is a valid branch
    assert np.array_equal(valid, reachable & robot.within_limits(sq))
    assert np.isfinite(sq).all()


@pytest.mark.parametrize("name", ROBOTS)
def test_branch_set_is_complete_against_numeric_ik_from_many_starts(name):
    make, _ = ROBOTS[name]
    robot = make()
    rng = np.random.default_rng(6)
    n_targets, n_starts = 12, 40
    q = _in_limits(robot, rng, n_targets)
    target = _target(robot, q)
    sols = ik_all(robot, target)
    reduced = target_kind(robot) in REDUCED  # numeric IK has no pitch row: it runs on the tool poses
    repeated = np.repeat(fk(robot, q) if reduced else target, n_starts, axis=0)
    res = ik_numeric(robot, repeated, q0=_in_limits(robot, rng, n_targets * n_starts), restarts=3, max_iter=100,
                     kind="pose" if reduced else None)
    assert res.success.mean() > 0.5  # the comparison has material
    qa = np.repeat(sols.q, n_starts, axis=0)
    valid = np.repeat(sols.valid, n_starts, axis=0)
    gap = np.where(valid, np.abs(wrap_angle(qa - res.q[:, None])).max(axis=-1), np.inf).min(axis=-1)
    assert gap[res.success].max() < 1e-6, "numeric IK found a solution that no branch returned"
    # and every valid branch of a target is found by some numeric start (the set is not padded)
    hit = np.abs(wrap_angle(qa - res.q[:, None])).max(axis=-1) < 1e-6
    hit &= res.success[:, None]
    hit_any = hit.reshape(n_targets, n_starts, -1).any(axis=1)
    same = sols.valid
    if reduced:  # a 4-DOF arm reaching over its back holds the tool upside down: a pose of its own
        same = same & (np.abs(fk(robot, sols.q) - fk(robot, q)[:, None]).max(axis=(-2, -1)) < 1e-9)
    assert hit_any.sum() >= 0.75 * same.sum()


def test_planar_2r_out_of_plane_and_out_of_reach():
    robot = _planar_2r()
    p = _target(robot, [0.3, -0.4])
    normal = robot.base[:3, 2]
    with pytest.raises(UnreachableError, match=r"out of reach by 0.01 m") as info:
        ik(robot, p + 0.01 * normal)
    assert info.value.distance == pytest.approx(0.01, abs=1e-12)
    sols = ik_all(robot, p + 1e-12 * normal)  # rounding-size height errors are tolerated
    assert sols.reachable.all()
    far = robot.base[:3, 3] + 0.15 * normal + 0.9 * robot.base[:3, 0]
    sols = ik_all(robot, far)
    assert not sols.reachable.any() and sols.distance > 0.3
    q = ik(robot, p, branch="elbow_down")
    assert np.allclose(_target(robot, q), p, atol=1e-12)


def test_shoulder_offset_front_and_back_reach_differently():
    """Far out only the front branches reach (the back ones would need the shoulder offset twice)."""
    kr5 = Robot.load("kr5")
    q = np.array([0.0, -0.05, -0.2, 0.2, 0.5, 0.1])  # arm stretched forwards
    T = fk(kr5, q)
    sols = ik_all(kr5, T)
    assert sols.reachable.tolist() == [True] * 4 + [False] * 4  # right_* reach, left_* do not
    assert np.abs(fk(kr5, sols.q[:4]) - T).max() < 1e-9
    assert np.all(np.isfinite(sols.q))
    with pytest.raises(UnreachableError, match="branch 'left_up_noflip' cannot reach"):
        ik(kr5, T, branch="left_up_noflip")


def test_benchmark_script_prints_full_success_and_ratios():
    """The acceptance benchmark (10,000 targets without --quick) passes in its quick form."""
    import re
    import subprocess
    import sys
    from pathlib import Path

    script = Path(__file__).resolve().parents[2] / "benchmarks" / "bench_ik_families.py"
    out = subprocess.run([sys.executable, str(script), "--quick"], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stdout + out.stderr
    rows = [ln for ln in out.stdout.splitlines() if "targets/s" in ln]
    assert len(rows) >= 3
    for row in rows:
        assert "solved 100.00%" in row and "(100.00%)" in row and re.search(r"ratio +[\d,]+x", row), row


def test_ur5_wrist_singularity_and_unreachable_targets():
    ur5 = Robot.load("ur5")
    q = np.array([0.3, -1.0, 1.2, 0.4, 0.0, 0.5])  # q5 = 0: axis 6 parallel to axes 2-4, only q4 + q6 is fixed
    T = fk(ur5, q)
    sols = ik_all(ur5, T)
    assert np.all(np.isfinite(sols.q)) and sols.reachable.sum() >= 4
    assert np.abs(fk(ur5, sols.q[sols.reachable]) - T).max() < 1e-9
    far = T.copy()
    far[:3, 3] *= 5.0
    with pytest.raises(UnreachableError, match="out of reach by") as info:
        ik(ur5, far)
    assert info.value.distance > 0.5
    q_ik = ik(ur5, fk(ur5, [0.1, -0.8, 1.0, -0.5, 0.7, 0.2]), branch="lun", q_near=None)
    assert np.abs(fk(ur5, q_ik) - fk(ur5, [0.1, -0.8, 1.0, -0.5, 0.7, 0.2])).max() < 1e-9


def test_4dof_position_pitch_targets():
    arm = _arm4()
    assert target_kind(arm) == "position_pitch"
    targets = np.array([[0.2, 0.1, 0.15, -0.5], [0.05, -0.2, 0.3, 0.8], [-0.1, 0.0, 0.05, -1.4]])
    sols = ik_all(arm, targets)
    assert sols.branches == ("elbow_up", "elbow_down", "back_elbow_up", "back_elbow_down")
    assert sols.reachable.all()
    reached = fk(arm, sols.q)
    assert np.abs(reached[..., :3, 3] - targets[:, None, :3]).max() < 1e-12
    # the pitch: elevation of the tool x axis above the horizontal, in the arm's plane, towards the target
    x = reached[..., :3, 0]
    radial = targets[:, None, :2] / np.linalg.norm(targets[:, :2], axis=1)[:, None, None]
    pitch = np.arctan2(x[..., 2], (x[..., :2] * radial).sum(-1))
    assert np.abs(pitch - targets[:, 3, None]).max() < 1e-12
    # the four branches are different configurations; the back ones turn the base by half a turn
    q = sols.q
    assert np.all(np.abs(q[:, 0] - q[:, 1]).max(axis=-1) > 1e-3)
    assert np.allclose(np.abs(wrap_angle(q[:, 2, 0] - q[:, 0, 0])), np.pi)
    # poses are targets too: the branches whose FK is the pose (the front ones of a front pose)
    T = pose_from_position_pitch(arm, targets)
    assert T.shape == (3, 4, 4)
    s = ik_all(arm, T)
    assert s.reachable[:, :2].all() and not s.reachable[:, 2:].any()
    assert np.abs(fk(arm, s.q[:, :2]) - T[:, None]).max() < 1e-12
    # an orientation no 4-DOF arm can take: a clear message, never "out of reach by inf"
    twisted = T[0].copy()
    twisted[:3, :3] = twisted[:3, :3] @ np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])
    s = ik_all(arm, twisted)
    assert not s.reachable.any() and np.isfinite(s.distance)
    with pytest.raises(UnreachableError, match="no configuration takes the orientation.*takes x y z pitch") as info:
        ik(arm, twisted)
    assert "inf" not in str(info.value)
    with pytest.raises(UnreachableError, match=r"out of reach by 0.5\d* m"):
        ik(arm, [0.0, 0.9, 0.1, 0.0])
    with pytest.raises(OptionError, match="need a 4-DOF yaw-pitch-pitch-pitch"):
        pose_from_position_pitch(Robot.load("puma560"), [0.2, 0.1, 0.15, -0.5])


@pytest.mark.parametrize("values, missing", [([0.2, 0.0, 0.1], "pitch missing"), ([0.2, 0.0], "z pitch missing"),
                                             ([0.2, 0.0, 0.1, 0.0, 0.3], None)])
def test_4dof_targets_of_the_wrong_size_say_what_the_arm_takes(values, missing):
    with pytest.raises(ShapeError, match="this arm takes x y z pitch") as info:
        ik(Robot.load("openmanipulator_x"), values)
    message = str(info.value)
    if missing:
        assert missing in message
    else:
        assert "got (5,)" in message and "missing" not in message


def test_5dof_targets_say_roll_is_missing():
    so101 = Robot.load("so101")
    assert target_kind(so101) == "position_pitch_roll"
    with pytest.raises(ShapeError, match="this arm takes x y z pitch roll; roll missing"):
        ik_all(so101, [0.2, 0.0, 0.1, -1.0])


#: the course arms of issue 25 (4-DOF pitch and 5-DOF pitch-roll targets)
COURSE_ARMS = ("openmanipulator_x", "so101", "al5d")


@pytest.mark.parametrize("evaluator", ["batch", "few"])
@pytest.mark.parametrize("name", COURSE_ARMS)
def test_course_arm_solves_10000_random_targets_on_every_branch(name, evaluator):
    """Random joints in the limits -> FK -> target -> IK: the start is always a valid branch, every
    branch's FK is the target, and every branch is the valid solution of some targets."""
    robot = Robot.load(name)
    rng = np.random.default_rng(25)
    q = _in_limits(robot, rng, 10_000)
    target = _target(robot, q)
    if evaluator == "batch":
        sols = ik_all(robot, target)
        sq, reach, valid = sols.q, sols.reachable, sols.valid
    else:  # a few targets per call
        parts = [ik_all(robot, target[k:k + FEW]) for k in range(0, len(target), FEW)]
        sq, reach, valid = (np.concatenate([getattr(p, f) for p in parts]) for f in ("q", "reachable", "valid"))
    err = np.abs(_difference(robot, _target(robot, sq), target[:, None])).max(axis=-1)
    assert err[reach].max() < 1e-9
    start = np.where(valid, np.abs(wrap_angle(sq - q[:, None])).max(axis=-1), np.inf).min(axis=-1)
    assert np.all(start < 1e-7), f"{np.mean(start < 1e-7):.2%} solved"
    assert valid.any(axis=0).all(), "every branch is the valid solution of some target"
    assert np.isfinite(sq).all()


def test_course_arm_pitch_is_the_elevation_and_roll_turns_about_the_approach():
    """pitch = elevation of the approach above the world horizontal (up = +z for all three files);
    a change of roll turns the tool about the approach and leaves point and approach in place."""
    from labkit.kinematics._ik_solvers import detect

    rng = np.random.default_rng(7)
    for name in COURSE_ARMS:
        robot = Robot.load(name)
        family, _ = detect(robot)
        q = _in_limits(robot, rng, 500)
        T = fk(robot, q)
        t = _target(robot, q)
        approach = T[:, :3, :3] @ family.approach_tool
        assert np.abs(np.sin(t[:, 3]) - approach[:, 2]).max() < 1e-12, name
        if robot.n == 5:
            turned = q.copy()
            turned[:, 4] += 0.3
            t2 = _target(robot, turned)
            assert np.abs(t2[:, :4] - t[:, :4]).max() < 1e-12
            assert np.abs(wrap_angle(t2[:, 4] - t[:, 4]) - 0.3 * family.s5).max() < 1e-12, name


def test_arm_move_to_takes_the_target_the_arm_needs():
    """``Arm.move_to`` on the virtual AL5D: x y z pitch roll moves there (nearest branch); four numbers
    say the roll is missing and nothing moves."""
    from labkit.arm import Arm

    al5d = Robot.load("al5d")
    q0 = np.array([0.3, -0.4, 0.5, 0.2, 0.1])
    target = _target(al5d, q0)
    with Arm("al5d", "sim://al5d?clock=lockstep&seed=0&calibrated=1") as arm:
        q = arm.move_to(target, wait=True)
        assert np.abs(_difference(al5d, _target(al5d, q), target)).max() < 1e-12
        assert np.abs(arm.read_joints() - q).max() < np.radians(2.0)
        before = arm.commanded_joints()
        with pytest.raises(ShapeError, match="this arm takes x y z pitch roll; roll missing"):
            arm.move_to(target[:4])
        assert np.array_equal(arm.commanded_joints(), before)


def test_spherical_arm_branches_front_back_and_boom_out_in():
    """``stanford``: the three-letter aliases pick the branches; the boom-in branches run the boom back through
    the shoulder (negative, outside the fixture's travel) and the back ones turn the waist by half a turn less
    twice the angle of the lateral offset seen from axis 1.
    ``spherical_rrp``: a point nearer the shoulder than the boom's offsets is out of reach by the gap."""
    arm = _fixture("stanford")()
    q = np.radians([20.0, 40.0, 0.0, 30.0, -50.0, 60.0])
    q[2] = 0.6
    T = fk(arm, q)
    sols = ik_all(arm, T)
    assert np.abs(ik(arm, T, branch="fon") - sols["front_out_noflip"]).max() == 0.0
    boom = sols.q[:, 2]
    out = np.array(["_out_" in b for b in sols.branches])
    assert (boom[out] > 0).all() and (boom[~out] < 0).all() and not sols.valid[~out].any()
    front = np.array([b.startswith("front") for b in sols.branches])
    # the wrist centre W (the tool point: d6 = 0) lies beside the arm plane (through axis 1, perpendicular to
    # axis 2 = z1 of frame 1, whose origin is the shoulder) by an offset off; both planes through W keep it
    F1 = fk_frames(arm, q)[1]
    r, off = np.hypot(*T[:2, 3]), (T[:3, 3] - F1[:3, 3]) @ F1[:3, 2]
    turn = np.pi - 2 * np.arctan2(off, np.sqrt(r * r - off * off))
    assert np.abs(np.abs(wrap_angle(sols.q[~front, 0] - sols.q[front, 0])) - turn).max() < 1e-12
    rrp = _spherical_rrp()
    S = np.array([0.0, 0.0, 0.3])  # the shoulder: on axis 1 (world z), d1 up
    sols = ik_all(rrp, S + [0.0, 0.0, 0.01])
    assert not sols.reachable.any() and sols.distance > 0.05
    with pytest.raises(UnreachableError, match="out of reach by"):
        ik(rrp, S + [0.0, 0.0, 0.01])


@pytest.mark.parametrize("make", [_arm4, _arm4_noa])
def test_4dof_pitch_is_the_elevation_of_the_tool_x_or_n_o_a_approach_axis(make):
    robot = make()
    q = np.radians([[0.0, 0.0, 0.0, 0.0], [30.0, -90.0, 0.0, -90.0], [0.0, -90.0, 0.0, 0.0]])
    T = fk(robot, q)
    axis = T[..., :3, 0] if robot.name == "arm4" else T[..., :3, 2]  # the approach direction
    assert target_kind(robot) == "position_pitch"
    pitch = target_from_pose(robot, T)[:, 3]
    assert np.allclose(pitch, np.arcsin(axis[:, 2]), atol=1e-12)  # elevation above the horizontal (axis 1 is up)
    assert np.allclose(np.degrees(pitch), [90.0, -90.0, 0.0], atol=1e-9)
