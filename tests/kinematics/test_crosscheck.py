"""Cross-checks against independent implementations (optional group, ``-m crosscheck``).

* roboticstoolbox-python: FK and geometric Jacobian of random robots of both DH
  conventions (revolute and prismatic joints, offsets, base and tool) to 1e-12;
  the PUMA 560 closed-form IK branch by branch against ``Puma560.ikine_a``; every one of its 24 DH
  models (FK, Jacobian, IK and numeric IK of the arm's own target kind).
* modern_robotics: FK and space Jacobian from the product of exponentials built
  from labkit's own joint axes at ``q = 0``.
"""

import numpy as np
import pytest
from conftest import require

from labkit.robot import Convention, JointType, Link, Robot
from labkit.kinematics import ik_all
from labkit.kinematics import fk, fk_frames, jacobian
from labkit.rotations import matrix_from_rpy

pytestmark = pytest.mark.crosscheck


def _random_transform(rng, scale=0.3):
    T = np.eye(4)
    T[:3, :3] = matrix_from_rpy(rng.uniform(-np.pi, np.pi, 3))
    T[:3, 3] = rng.uniform(-scale, scale, 3)
    return T


def _random_robot(rng, convention):
    n = int(rng.integers(2, 8))
    links = []
    for _ in range(n):
        prismatic = rng.random() < 0.3
        alpha = rng.choice([0.0, np.pi / 2, -np.pi / 2, np.pi, rng.uniform(-np.pi, np.pi)])
        links.append(
            Link(
                a=float(rng.uniform(-0.5, 0.5)) if rng.random() < 0.7 else 0.0,
                alpha=float(alpha),
                d=float(rng.uniform(-0.5, 0.5)) if rng.random() < 0.7 else 0.0,
                theta=float(rng.uniform(-np.pi, np.pi)) if rng.random() < 0.5 else 0.0,
                joint_type=JointType.PRISMATIC if prismatic else JointType.REVOLUTE,
                limits=(-1.0, 1.0) if prismatic else (-np.pi, np.pi),
            )
        )
    return Robot(
        name="random", links=tuple(links), convention=convention,
        base=_random_transform(rng), tool=_random_transform(rng),
    )


def _rtb_model(robot):
    rtb = require("roboticstoolbox")
    from spatialmath import SE3

    links = []
    for lk in robot.links:
        if robot.convention is Convention.STANDARD:
            cls = rtb.RevoluteDH if lk.is_revolute else rtb.PrismaticDH
        else:
            cls = rtb.RevoluteMDH if lk.is_revolute else rtb.PrismaticMDH
        if lk.is_revolute:
            links.append(cls(a=lk.a, alpha=lk.alpha, d=lk.d, offset=lk.theta, flip=lk.flip))
        else:
            links.append(cls(a=lk.a, alpha=lk.alpha, theta=lk.theta, offset=lk.d, qlim=[-5, 5], flip=lk.flip))
    return rtb.DHRobot(links, base=SE3(robot.base, check=False), tool=SE3(robot.tool, check=False))


@pytest.mark.parametrize("convention", [Convention.STANDARD, Convention.MODIFIED])
def test_fk_and_jacobian_match_roboticstoolbox(convention):
    rng = np.random.default_rng(20 if convention is Convention.STANDARD else 21)
    for _ in range(12):
        robot = _random_robot(rng, convention)
        ref = _rtb_model(robot)
        q = rng.uniform(-1.5, 1.5, size=(8, robot.n))
        T = fk(robot, q)  # batched
        J0 = jacobian(robot, q)
        Je = jacobian(robot, q, frame="tool")
        for k in range(len(q)):
            assert np.abs(T[k] - ref.fkine(q[k]).A).max() < 1e-12
            assert np.abs(J0[k] - ref.jacob0(q[k])).max() < 1e-12
            assert np.abs(Je[k] - ref.jacobe(q[k])).max() < 1e-12


@pytest.mark.parametrize("convention", [Convention.STANDARD, Convention.MODIFIED])
def test_flipped_joints_match_roboticstoolbox(convention):
    """``Link.flip`` is rtb's ``flip``: FK and both Jacobians to 1e-12, revolute and prismatic."""
    rng = np.random.default_rng(30 if convention is Convention.STANDARD else 31)
    n_flipped = 0
    for _ in range(10):
        robot = _random_robot(rng, convention)
        flips = rng.random(robot.n) < 0.5
        flips[rng.integers(robot.n)] = True  # at least one flipped joint per robot
        n_flipped += int(flips.sum())
        robot = robot.replace(links=tuple(lk.__class__(**{**lk.__dict__, "flip": bool(f)})
                                          for lk, f in zip(robot.links, flips)))
        ref = _rtb_model(robot)
        assert sum(link.isflip for link in ref.links) == flips.sum()
        q = rng.uniform(-1.5, 1.5, size=(6, robot.n))
        T, J0, Je = fk(robot, q), jacobian(robot, q), jacobian(robot, q, frame="tool")
        for k in range(len(q)):
            assert np.abs(T[k] - ref.fkine(q[k]).A).max() < 1e-12
            assert np.abs(J0[k] - ref.jacob0(q[k])).max() < 1e-12
            assert np.abs(Je[k] - ref.jacobe(q[k])).max() < 1e-12
    assert n_flipped >= 10


def test_bundled_robots_match_roboticstoolbox():
    rng = np.random.default_rng(22)
    for name in ("arduino_arm_3dof", "puma560", "puma600_seed002", "rpp_seed002", "planar3r_seed003", "irb140", "kr5",
                 "ur5"):
        robot = Robot.load(name)
        ref = _rtb_model(robot)
        for qk in rng.uniform(-1.0, 1.0, size=(5, robot.n)):
            assert np.abs(fk(robot, qk) - ref.fkine(qk).A).max() < 1e-12
            assert np.abs(jacobian(robot, qk) - ref.jacob0(qk)).max() < 1e-12


@pytest.mark.parametrize("name, model", [("irb140", "IRB140"), ("kr5", "KR5"), ("ur5", "UR5")])
def test_new_bundled_arms_match_their_rtb_models(name, model):
    rtb = require("roboticstoolbox")
    ref = getattr(rtb.models.DH, model)()
    robot = Robot.load(name)
    if ref.qlim is not None and name != "ur5":  # rtb's UR5 has no limits; the file has +-360 deg
        assert np.allclose(robot.joint_limits, np.asarray(ref.qlim).T)
    for qk in np.random.default_rng(26).uniform(-2, 2, size=(10, 6)):
        assert np.abs(fk(robot, qk) - ref.fkine(qk).A).max() < 1e-12


def test_puma560_fk_matches_the_rtb_model():
    rtb = require("roboticstoolbox")
    ref = rtb.models.DH.Puma560()
    puma = Robot.load("puma560")
    for qk in np.random.default_rng(23).uniform(-2, 2, size=(10, 6)):
        assert np.abs(fk(puma, qk) - ref.fkine(qk).A).max() < 1e-12


def test_puma560_ik_branches_match_rtb_ikine_a():
    """labkit's 8 PUMA branches are rtb's configurations l/r x u/d x n/f, name for name."""
    rtb = require("roboticstoolbox")
    ref = rtb.models.DH.Puma560()
    puma = Robot.load("puma560")
    rng = np.random.default_rng(24)
    lim = puma.joint_limits
    q = rng.uniform(lim[:, 0], lim[:, 1], size=(60, 6))
    T = fk(puma, q)
    sols = ik_all(puma, T)
    for k, name in enumerate(sols.branches):
        config = "".join(part[0] for part in name.split("_"))  # right_up_noflip -> "run"
        theirs = np.asarray(ref.ikine_a(T, config=config).q)
        diff = np.remainder(sols.q[:, k] - theirs + np.pi, 2 * np.pi) - np.pi
        assert np.abs(diff).max() < 1e-8, name


def test_fk_and_jacobian_match_modern_robotics_product_of_exponentials():
    mr = require("modern_robotics")
    rng = np.random.default_rng(25)
    for robot in [Robot.load("puma560"), Robot.load("puma600_seed002"), _random_robot(rng, Convention.MODIFIED)]:
        n = robot.n
        F = fk_frames(robot, np.zeros(n))
        idx = np.arange(1, n + 1) if robot.convention is Convention.MODIFIED else np.arange(n)
        S = []
        for i, lk in zip(idx, robot.links):
            w, p = F[i, :3, 2], F[i, :3, 3]
            S.append(np.r_[w, -np.cross(w, p)] if lk.is_revolute else np.r_[0, 0, 0, w])
        S = np.array(S).T
        M = F[n + 1]
        for qk in rng.uniform(-1, 1, size=(5, n)):
            T = mr.FKinSpace(M, S, qk)
            assert np.abs(fk(robot, qk) - T).max() < 1e-12
            Js = mr.JacobianSpace(S, qk)  # rows [w; v at the world origin]
            w, v0 = Js[:3], Js[3:]
            v_tool = v0 + np.cross(w.T, T[:3, 3]).T
            assert np.abs(jacobian(robot, qk) - np.r_[v_tool, w]).max() < 1e-12


@pytest.mark.slow
def test_benchmark_script_runs_quick():
    """The benchmark prints every row with ratios against its peers (not a timed test): run in
    its ``--smoke`` mode (tiny batches, one repeat), which prints the same rows as a full run."""
    import re
    import subprocess
    import sys
    from pathlib import Path

    import importlib.util

    require("roboticstoolbox")
    has_numba = importlib.util.find_spec("numba") is not None  # the `bench` extra; CI runs without it
    script = Path(__file__).resolve().parents[2] / "benchmarks" / "bench_kinematics.py"
    out = subprocess.run([sys.executable, str(script), "--smoke"], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    for call in ("fk", "jacobian", "ik one branch"):  # single calls against rtb's C backend
        line = next(ln for ln in lines if ln.startswith("3-DOF arm") and f" {call} " in ln)
        assert re.search(r"\d+\.\d+\s+\d+\.\d\d\b", line), line  # rtb time and ratio printed
    for row in ("FK", "Jacobian"):  # batched against the numba chain, with the bandwidth floor
        line = next(ln for ln in lines if ln.startswith(row) and " 1,000 " in ln)
        assert re.search(r"\d+\.\d+M\s+\d+\.\d+$", line), line  # floor and % of the floor
        assert bool(re.search(r"\d\.\d\dx", line)) == has_numba, line  # ratio to the numba chain
    line = next(ln for ln in lines if ln.startswith("analytic IK"))
    assert re.search(r"[\d,]+x$", line), line  # a ratio against rtb's ikine_a is printed
    assert out.stdout.count("success 100.0%") >= 4  # numeric IK, with and without a closed form
    assert "rtb ik_LM" in out.stdout and "peak" in out.stdout and "labkit --help" in out.stdout


#: the course arms of issue 25 and their approach direction in tool coordinates (the files' tool frames)
COURSE_APPROACH = {"openmanipulator_x": [1.0, 0.0, 0.0], "so101": [0.0, -1.0, 0.0], "al5d": [0.0, 0.0, 1.0]}


@pytest.mark.parametrize("name", sorted(COURSE_APPROACH))
def test_course_arm_ik_branches_reach_the_target_in_roboticstoolbox(name):
    """Every reachable branch of the 4- and 5-DOF closed forms, put through roboticstoolbox's FK of a
    DH model built from the same rows: the tool point is the target, the approach has the target's
    pitch (elevation above the world horizontal) and, for 5-DOF arms, turning q5 turns the roll."""
    from labkit.kinematics import target_from_pose

    robot = Robot.load(name)
    ref = _rtb_model(robot)
    rng = np.random.default_rng(251)
    lim = robot.joint_limits
    q = rng.uniform(lim[:, 0], lim[:, 1], size=(40, robot.n))
    target = target_from_pose(robot, fk(robot, q))
    sols = ik_all(robot, target)
    assert sols.reachable.any(axis=1).all()
    approach = np.array(COURSE_APPROACH[name])
    checked = 0
    for k in range(len(q)):
        for b in np.flatnonzero(sols.reachable[k]):
            T = ref.fkine(sols.q[k, b]).A
            assert np.abs(T[:3, 3] - target[k, :3]).max() < 1e-9
            a = T[:3, :3] @ approach
            assert abs(a[2] - np.sin(target[k, 3])) < 1e-9  # elevation above the horizontal (up = +z)
            # ... and its horizontal part points away from axis 1 (through the base origin) towards the
            # target by cos(pitch) (SO-101's 0.18 mm lateral offset tilts the arm's plane by < 0.004 rad
            # at 50 mm from axis 1)
            out = target[k, :2] - robot.base[:2, 3]
            if np.linalg.norm(out) > 0.05:
                assert np.abs(a[:2] - np.cos(target[k, 3]) * out / np.linalg.norm(out)).max() < 1e-2
            checked += 1
    assert checked >= 2 * len(q)


def test_al5d_file_is_roboticstoolbox_al5d_plus_a_wrist_rotate():
    """The bundled al5d.toml: joints 1-4 are roboticstoolbox's AL5D model (its tool point and the
    approach along its tool x), and the wrist rotate turns the tool about that approach."""
    rtb = require("roboticstoolbox")
    model = rtb.models.DH.AL5D()
    robot = Robot.load("al5d")
    rng = np.random.default_rng(252)
    q = rng.uniform(robot.joint_limits[:, 0], robot.joint_limits[:, 1], size=(50, 5))
    T = fk(robot, q)
    turn = []
    for k in range(len(q)):
        R = model.fkine(q[k, :4]).A
        assert np.abs(T[k, :3, 3] - R[:3, 3]).max() < 1e-12
        assert np.abs(T[k, :3, 2] - R[:3, 0]).max() < 1e-12
        y = T[k, :3, 1]  # the tool y axis, in RTB's tool (y, z) plane
        turn.append(np.arctan2(y @ R[:3, 2], y @ R[:3, 1]) - q[k, 4])
    # q5 turns the tool about the approach, right-handed: a constant angle apart from RTB's tool frame
    turn = np.angle(np.exp(1j * (np.array(turn) - turn[0])))
    assert np.abs(turn).max() < 1e-9


def _random_scara(rng, convention):
    """A SCARA (three revolute joints and a quill, every axis parallel) of random lengths, quill position and
    signs (twists of 0 or pi, flipped joints), on a random base with a random tool."""
    quill = int(rng.integers(4))
    links = []
    for j in range(4):
        prismatic = j == quill
        links.append(Link(
            a=float(rng.uniform(0.15, 0.4)) if rng.random() < 0.7 else 0.0,
            alpha=float(rng.choice([0.0, np.pi])), d=float(rng.uniform(-0.2, 0.3)),
            theta=float(rng.uniform(-np.pi, np.pi)) if rng.random() < 0.5 else 0.0,
            joint_type=JointType.PRISMATIC if prismatic else JointType.REVOLUTE,
            limits=(-0.3, 0.3) if prismatic else (-np.pi, np.pi), flip=bool(rng.random() < 0.3),
        ))
    base = np.eye(4)
    base[:3, :3] = matrix_from_rpy(rng.uniform(-0.4, 0.4, 3))
    base[:3, 3] = rng.uniform(-0.3, 0.3, 3)
    return Robot(name="scara", links=tuple(links), convention=convention, base=base, tool=_random_transform(rng))


def _yaw(T, k):
    """Yaw of poses ``T`` (N, 4, 4) about the unit axis ``k``, from the world axis least along ``k`` projected."""
    e = np.eye(3)[int(np.argmin(np.abs(k)))]
    u = e - k * (e @ k)
    u /= np.linalg.norm(u)
    ref = T[:, :3, 0]
    return np.arctan2(ref @ np.cross(k, u), ref @ u)


@pytest.mark.parametrize("convention", [Convention.STANDARD, Convention.MODIFIED])
def test_scara_closed_form_reaches_roboticstoolbox_poses(convention):
    """Random SCARA models built in roboticstoolbox (DHRobot of RevoluteDH/PrismaticDH or the MDH links):
    targets x y z yaw read from rtb's ``fkine``; every branch labkit returns, put through rtb's ``fkine``, has
    the target's tool point and yaw, and the configuration the target came from is a valid branch."""
    from labkit.kinematics import solver_for

    rng = np.random.default_rng(40 if convention is Convention.STANDARD else 41)
    tested = 0
    while tested < 8:
        robot = _random_scara(rng, convention)
        if solver_for(robot).value != "scara":  # two revolute axes drawn on one line: no elbow
            continue
        tested += 1
        ref = _rtb_model(robot)
        k = ref.base.A[:3, 2] if convention is Convention.STANDARD else (ref.base * ref.links[0].A(0.0)).A[:3, 2]
        k = k if k[2] > 0 else -k  # the axes' direction on the side of up (+z)
        lim = robot.joint_limits
        q = rng.uniform(lim[:, 0], lim[:, 1], size=(20, 4))
        T = np.array([ref.fkine(qk).A for qk in q])
        target = np.column_stack([T[:, :3, 3], _yaw(T, k)])
        sols = ik_all(robot, target)
        assert sols.branches == ("elbow_left", "elbow_right") and sols.reachable.all()
        for i in range(len(q)):
            for qb in sols.q[i]:
                Tb = ref.fkine(qb).A
                assert np.abs(Tb[:3, 3] - target[i, :3]).max() < 1e-9
                dyaw = _yaw(Tb[None], k)[0] - target[i, 3]
                assert abs(np.remainder(dyaw + np.pi, 2 * np.pi) - np.pi) < 1e-9
        gap = np.abs(np.remainder(sols.q - q[:, None] + np.pi, 2 * np.pi) - np.pi).max(axis=-1)
        assert np.where(sols.valid, gap, np.inf).min(axis=1).max() < 1e-7


def test_rtb_cobra600_scara_closed_form():
    """roboticstoolbox's Omron Cobra 600 (RRPR, quill pointing down): both elbows reach rtb's poses, the
    right elbow (counterclockwise seen from above) has q2 > 0 on this arm, and numeric IK of the same
    x y z yaw target lands on one of the two branches."""
    from labkit.kinematics import ik_numeric, solver_for, target_from_pose

    rtb = require("roboticstoolbox")
    ref = rtb.models.DH.Cobra600()
    links = tuple(
        Link(a=lk.a, alpha=lk.alpha, d=lk.d, theta=lk.offset, limits=tuple(ref.qlim[:, j])) if lk.isrevolute
        else Link(a=lk.a, alpha=lk.alpha, theta=lk.theta, d=lk.offset, joint_type="prismatic",
                  limits=tuple(ref.qlim[:, j]))
        for j, lk in enumerate(ref.links))
    cobra = Robot("cobra600", links)
    assert solver_for(cobra).value == "scara"
    rng = np.random.default_rng(42)
    q = rng.uniform(ref.qlim[0], ref.qlim[1], size=(40, 4))
    T = np.array([ref.fkine(qk).A for qk in q])
    target = np.column_stack([T[:, :3, 3], np.arctan2(T[:, 1, 0], T[:, 0, 0])])  # axis 1 is world +z
    assert np.abs(target_from_pose(cobra, T) - target).max() < 1e-12
    sols = ik_all(cobra, target)
    for i in range(len(q)):
        for qb in sols.q[i]:
            Tb = ref.fkine(qb).A
            assert np.abs(Tb[:3, 3] - target[i, :3]).max() < 1e-9
            assert abs(np.remainder(np.arctan2(Tb[1, 0], Tb[0, 0]) - target[i, 3] + np.pi, 2 * np.pi) - np.pi) < 1e-9
    assert (sols["elbow_right"][:, 1] > 0).all() and (sols["elbow_left"][:, 1] < 0).all()
    res = ik_numeric(cobra, target[:10])
    assert res.success.all()
    gap = np.abs(sols.q[:10] - res.q[:, None]).max(axis=-1).min(axis=-1)
    assert gap.max() < 1e-6


def _stanford_labkit(ref):
    """A labkit Robot with the DH rows and limits of an rtb DHRobot (standard DH, no base or tool)."""
    return Robot(ref.name, tuple(
        Link(a=lk.a, alpha=lk.alpha, d=lk.d, theta=lk.offset, limits=tuple(ref.qlim[:, j])) if lk.isrevolute
        else Link(a=lk.a, alpha=lk.alpha, theta=lk.theta, d=lk.offset, joint_type="prismatic",
                  limits=tuple(ref.qlim[:, j]))
        for j, lk in enumerate(ref.links)))


def test_rtb_stanford_arm_closed_form():
    """roboticstoolbox's Stanford arm (RRPRRR) and the bundled-style fixture: the same FK; the closed form
    ``stanford`` returns 8 branches (front/back shoulder x boom out/in x wrist flip), every one reaching
    rtb's pose to 1e-9 through rtb's ``fkine``, pairwise different, the configuration the pose came from a
    valid branch; the boom-in branches run the boom negative (outside the 0.3-1.27 m travel), so at most 4
    are valid; numeric IK of the same pose lands on a branch."""
    from pathlib import Path

    from labkit.kinematics import ik_numeric, solver_for

    rtb = require("roboticstoolbox")
    ref = rtb.models.DH.Stanford()
    arm = _stanford_labkit(ref)
    fixture = Robot.load(Path(__file__).resolve().parent / "robots" / "stanford.toml")
    assert solver_for(arm).value == "stanford" and solver_for(fixture).value == "stanford"
    rng = np.random.default_rng(44)
    q = rng.uniform(ref.qlim[0], ref.qlim[1], size=(40, 6))
    T = np.array([ref.fkine(qk).A for qk in q])
    assert np.abs(fk(fixture, q) - T).max() < 1e-12 and np.abs(fk(arm, q) - T).max() < 1e-12
    sols = ik_all(arm, T)
    assert sols.branches == tuple(f"{s}_{b}_{w}" for s in ("front", "back") for b in ("out", "in")
                                  for w in ("noflip", "flip"))
    assert sols.reachable.all()
    for i in range(len(q)):
        for qb in sols.q[i]:
            assert np.abs(ref.fkine(qb).A - T[i]).max() < 1e-9
    diff = np.abs(sols.q[:, :, None] - sols.q[:, None, :]).max(axis=-1) + np.eye(8) * 1e3
    assert diff.min() > 1e-6  # 8 different configurations per pose
    boom_in = np.array(["_in_" in b for b in sols.branches])
    assert (sols.q[:, boom_in, 2] < 0).all() and not sols.valid[:, boom_in].any()
    assert (sols.valid.sum(axis=1) >= 1).all() and (sols.valid.sum(axis=1) <= 4).all()
    gap = np.abs(np.remainder(sols.q - q[:, None] + np.pi, 2 * np.pi) - np.pi).max(axis=-1)
    assert np.where(sols.valid, gap, np.inf).min(axis=1).max() < 1e-7
    res = ik_numeric(arm, T[:10])
    assert res.success.all()
    assert np.abs(sols.q[:10] - res.q[:, None]).max(axis=-1).min(axis=-1).max() < 1e-6


def _random_spherical(rng, convention, wrist):
    """A spherical arm (yaw, pitch meeting it, a boom perpendicular to the pitch axis; with ``wrist`` three
    more revolute axes meeting in a point) of random lengths, offsets, twists of +-90 deg and flips, on a
    random base with a random tool."""
    def right():
        return float(rng.choice([np.pi / 2, -np.pi / 2]))

    def length(lo=-0.3, hi=0.3):
        return float(rng.uniform(lo, hi)) if rng.random() < 0.7 else 0.0

    def theta():
        return float(rng.uniform(-np.pi, np.pi)) if rng.random() < 0.5 else 0.0

    def joint(a, alpha, d, prismatic=False):
        return Link(a=a, alpha=alpha, d=d, theta=theta(), flip=bool(rng.random() < 0.3),
                    joint_type=JointType.PRISMATIC if prismatic else JointType.REVOLUTE,
                    limits=(-1.0, 1.0) if prismatic else (-np.pi, np.pi))

    if convention is Convention.STANDARD:  # a, alpha of link i lead from axis i to axis i + 1
        links = [joint(0.0, right(), length(0.1, 0.5)), joint(length(), right(), length()),
                 joint(length(), right(), length(), prismatic=True)]
        if wrist:
            links += [joint(0.0, right(), 0.0), joint(0.0, right(), 0.0), joint(length(), theta(), length())]
    else:  # a, alpha of link i lead from axis i - 1 to axis i
        links = [joint(length(), theta(), length(0.1, 0.5)), joint(0.0, right(), length()),
                 joint(length(), right(), length(), prismatic=True)]
        if wrist:
            links += [joint(length(), theta(), length()), joint(0.0, right(), 0.0), joint(0.0, right(), 0.0)]
    base = np.eye(4)
    base[:3, :3] = matrix_from_rpy(rng.uniform(-0.4, 0.4, 3))
    base[:3, 3] = rng.uniform(-0.3, 0.3, 3)
    return Robot(name="spherical", links=tuple(links), convention=convention, base=base,
                 tool=_random_transform(rng))


@pytest.mark.parametrize("wrist", [False, True])
@pytest.mark.parametrize("convention", [Convention.STANDARD, Convention.MODIFIED])
def test_spherical_arms_closed_form_reaches_roboticstoolbox_poses(convention, wrist):
    """Random spherical RRP arms (x y z targets, 4 branches) and RRP arms with a spherical wrist (poses, 8
    branches) built in roboticstoolbox: every branch labkit returns, through rtb's ``fkine``, reaches the
    target to 1e-9, the branches differ, and the configuration the target came from is one of them."""
    from labkit.kinematics import solver_for

    rng = np.random.default_rng(50 + 2 * wrist + (convention is Convention.MODIFIED))
    family, m = ("stanford", 8) if wrist else ("spherical_rrp", 4)
    for _ in range(8):
        robot = _random_spherical(rng, convention, wrist)
        assert solver_for(robot).value == family
        ref = _rtb_model(robot)
        q = rng.uniform(robot.joint_limits[:, 0], robot.joint_limits[:, 1], size=(20, robot.n))
        T = np.array([ref.fkine(qk).A for qk in q])
        sols = ik_all(robot, T if wrist else T[:, :3, 3])
        assert len(sols.branches) == m and sols.reachable.all()
        for i in range(len(q)):
            for qb in sols.q[i]:
                Tb = ref.fkine(qb).A
                assert np.abs((Tb - T[i]) if wrist else (Tb[:3, 3] - T[i, :3, 3])).max() < 1e-9
        diff = np.abs(sols.q[:, :, None] - sols.q[:, None, :]).max(axis=-1) + np.eye(m) * 1e3
        assert diff.min() > 1e-9
        gap = np.abs(np.remainder(sols.q - q[:, None] + np.pi, 2 * np.pi) - np.pi).max(axis=-1)
        assert gap.min(axis=1).max() < 1e-7


#: every DH model roboticstoolbox-python ships (``rtb.models.DH``)
RTB_DH_MODELS = ("AL5D", "Ball", "Baxter", "Cobra600", "Coil", "Hyper", "Hyper3d", "IRB140", "Jaco", "KR5", "LWR4",
                 "Mico", "Orion5", "P8", "Panda", "Planar2", "Planar3", "Puma560", "Sawyer", "Stanford", "TwoLink",
                 "UR10", "UR3", "UR5")


def test_the_list_of_rtb_dh_models_is_complete():
    import inspect

    rtb = require("roboticstoolbox")
    assert set(RTB_DH_MODELS) == {name for name, _ in inspect.getmembers(rtb.models.DH, inspect.isclass)}


@pytest.mark.parametrize("name", RTB_DH_MODELS)
def test_every_rtb_dh_model_fk_jacobian_and_ik(name):
    """Each of roboticstoolbox's 24 DH models: labkit's FK and Jacobian equal rtb's ``fkine`` and ``jacob0``
    at random in-limit configurations; IK of the arm's own target kind (its closed form, or numeric IK) reaches
    every target, each reachable branch's FK on the target; ``ik_numeric`` takes the same target."""
    from labkit.kinematics import ik_numeric, target_error, target_from_pose
    from tests.dynamics.test_crosscheck import _from_rtb

    rtb = require("roboticstoolbox")
    model = getattr(rtb.models.DH, name)()
    robot = _from_rtb(model)  # (its inertias and motors play no part here)
    rng = np.random.default_rng(sum(map(ord, name)))
    lim = robot.joint_limits
    q = rng.uniform(np.maximum(lim[:, 0], -np.pi), np.minimum(lim[:, 1], np.pi), size=(8, robot.n))
    T, J = fk(robot, q), jacobian(robot, q)
    scale = max(robot.reach, 1.0)
    for k in range(len(q)):
        assert np.abs(T[k] - model.fkine(q[k]).A).max() < 1e-12 * scale
        assert np.abs(J[k] - model.jacob0(q[k])).max() < 1e-12 * scale
    target = target_from_pose(robot, T[:6])  # (not 4 targets: 4 x 4 would be one pose)
    sols = ik_all(robot, target)
    assert sols.reachable.any(axis=-1).all()
    for k in range(len(target)):
        for b in np.flatnonzero(sols.reachable[k]):
            assert target_error(robot, sols.q[k, b], target[k]) < 1e-8 * scale
    res = ik_numeric(robot, target, seed=1)
    assert res.success.all() and robot.within_limits(res.q).all()
    assert max(target_error(robot, qk, t) for qk, t in zip(res.q, target)) < 1e-8 * scale
