"""Dynamics cross-checked against independent implementations (optional group, ``-m crosscheck``).

* roboticstoolbox-python: every DH model that carries dynamics (Puma560, Stanford, Panda,
  UR3/5/10, IRB140, P8, TwoLink) against its ``rne``, ``inertia``, ``coriolis``,
  ``gravload`` and ``accel`` on random states, to 1e-9 relative.
* modern_robotics: ``InverseDynamics`` and ``MassMatrix`` of random robots (both DH
  conventions, prismatic joints, flips, a rotated base) built from labkit's joint axes at
  ``q = 0``.
* pinocchio: RNEA and CRBA on URDFs with inertials: the rtb-data KUKA files and generated
  chains with fixed joints, rotated inertial frames, a fixed side branch and a moving one.
"""

import math
from pathlib import Path

import numpy as np
import pytest
from conftest import require

from labkit import dynamics as D
from labkit.exceptions import DynamicsError
from labkit.kinematics import fk_frames
from labkit.robot import Convention, JointType, Link, LinkInertia, Motor, Robot
from labkit.rotations import matrix_from_rpy

pytestmark = pytest.mark.crosscheck

RTB_MODELS = ["Puma560", "Stanford", "Panda", "UR3", "UR5", "UR10", "IRB140", "P8", "TwoLink"]
#: models whose every joint moves some mass (a positive definite M): rtb's accel is defined
PD_MODELS = {"Puma560", "Stanford", "Panda", "UR10", "TwoLink", "P8"}
#: roboticstoolbox 1.5's compiled ``rne`` is wrong for a rotated base with a prismatic joint (P8: 4 N m off
#: on a 2-link example) while its ``rne_python`` agrees with modern_robotics and labkit: its own
#: inertia/coriolis/gravload/accel are run on ``rne_python`` for these models
C_RNE_WRONG = {"P8"}
REL = 1e-9


def _rel(a, b, scale=None):
    """Largest difference relative to the reference's largest entry (or to ``scale`` where the reference may be 0)."""
    return float(np.abs(np.asarray(a) - np.asarray(b)).max() / max(np.abs(b).max(), scale or 1e-300))


def _from_rtb(model):
    """A labkit Robot with the same DH rows, base, tool, inertias and motors as an rtb DHRobot."""
    links = []
    for lk in model.links:
        rev = lk.isrevolute
        qlim = lk.qlim if lk.qlim is not None else ([-math.pi, math.pi] if rev else [-1.0, 1.0])
        I = np.asarray(lk.I, dtype=float)
        links.append(Link(
            a=float(lk.a), alpha=float(lk.alpha), d=float(lk.d if rev else lk.offset),
            theta=float(lk.offset if rev else lk.theta), joint_type="revolute" if rev else "prismatic",
            limits=(float(qlim[0]), float(qlim[1])), flip=bool(lk.isflip),
            inertial=LinkInertia.from_matrix(float(lk.m), np.asarray(lk.r, dtype=float).reshape(3), I),
            motor=Motor(float(lk.Jm), float(lk.G), float(lk.B), tuple(float(v) for v in np.ravel(lk.Tc))),
        ))
    return Robot(name=model.name.replace("/", "_") or "rtb", links=tuple(links),
                 convention=Convention.MODIFIED if model.mdh else Convention.STANDARD,
                 base=model.base.A, tool=model.tool.A)


@pytest.mark.parametrize("name", RTB_MODELS)
def test_roboticstoolbox_dh_models(name):
    rtb = require("roboticstoolbox")
    model = getattr(rtb.models.DH, name)()
    if name in C_RNE_WRONG:
        model.rne = model.rne_python
    robot = _from_rtb(model)
    g = np.asarray(model.gravity, dtype=float)
    rng = np.random.default_rng(sum(map(ord, name)))
    q, qd, qdd = (rng.uniform(-1.5, 1.5, size=(6, robot.n)) for _ in range(3))
    tau = D.inverse_dynamics(robot, q, qd, qdd, gravity=g)  # batched
    M = D.mass_matrix(robot, q)
    C = D.coriolis_matrix(robot, q, qd)
    G = D.gravity_torques(robot, q, gravity=g)
    for k in range(len(q)):
        assert _rel(tau[k], model.rne(q[k], qd[k], qdd[k], gravity=g)) < REL
        assert _rel(M[k], model.inertia(q[k])) < REL
        assert _rel(C[k], model.coriolis(q[k], qd[k])) < REL
        assert _rel(G[k], model.gravload(q[k], gravity=g)) < REL
    pd = bool(np.all(np.linalg.eigvalsh(M)[:, 0] > 1e-9 * np.abs(M).max()))
    assert pd == (name in PD_MODELS)
    torque = rng.uniform(-20, 20, size=(6, robot.n))
    if pd:
        acc = D.forward_dynamics(robot, q, qd, torque, gravity=g)
        for k in range(len(q)):
            assert _rel(acc[k], model.accel(q[k], qd[k], torque[k], gravity=g)) < REL
    else:
        with pytest.raises(DynamicsError, match="singular"):
            D.forward_dynamics(robot, q, qd, torque, gravity=g)


def _random_inertial(rng):
    A = rng.normal(size=(3, 3)) * 0.05
    return LinkInertia.from_matrix(float(rng.uniform(0.2, 3.0)), rng.uniform(-0.2, 0.2, 3), A @ A.T + 1e-3 * np.eye(3))


def _random_robot(rng, convention):
    n = int(rng.integers(2, 7))
    links = []
    for _ in range(n):
        prismatic = rng.random() < 0.3
        links.append(Link(
            a=float(rng.uniform(-0.5, 0.5)), alpha=float(rng.choice([0.0, np.pi / 2, -np.pi / 2, rng.uniform(-3, 3)])),
            d=float(rng.uniform(-0.5, 0.5)), theta=float(rng.uniform(-np.pi, np.pi)),
            joint_type=JointType.PRISMATIC if prismatic else JointType.REVOLUTE,
            limits=(-1.0, 1.0) if prismatic else (-np.pi, np.pi), flip=bool(rng.random() < 0.3),
            inertial=_random_inertial(rng),
        ))
    base = np.eye(4)
    base[:3, :3] = matrix_from_rpy(rng.uniform(-np.pi, np.pi, 3))
    base[:3, 3] = rng.uniform(-0.3, 0.3, 3)
    return Robot(name="random", links=tuple(links), convention=convention, base=base)


def _modern_robotics_model(robot):
    """Mlist, Glist, Slist of modern_robotics from labkit's frames at q = 0 (world = space frame)."""
    T = fk_frames(robot, np.zeros(robot.n))
    n = robot.n
    carrier = T[:n] if robot.convention is Convention.STANDARD else T[1:n + 1]
    S, coms, G = [], [], []
    for i, lk in enumerate(robot.links):
        s = carrier[i, :3, 2] * (-1.0 if lk.flip else 1.0)
        p = carrier[i, :3, 3]
        S.append(np.r_[s, -np.cross(s, p)] if lk.is_revolute else np.r_[0, 0, 0, s])
        C = T[i + 1].copy()
        C[:3, 3] = T[i + 1, :3, :3] @ np.array(lk.inertial.com) + T[i + 1, :3, 3]
        coms.append(C)
        G.append(np.block([[lk.inertial.matrix, np.zeros((3, 3))],
                           [np.zeros((3, 3)), lk.inertial.mass * np.eye(3)]]))
    Mlist = [coms[0]] + [np.linalg.inv(coms[i - 1]) @ coms[i] for i in range(1, n)] + [np.eye(4)]
    return Mlist, G, np.array(S).T


@pytest.mark.parametrize("convention", [Convention.STANDARD, Convention.MODIFIED])
def test_modern_robotics_inverse_dynamics_and_mass_matrix(convention):
    mr = require("modern_robotics")
    rng = np.random.default_rng(38 + (convention is Convention.MODIFIED))
    for _ in range(8):
        robot = _random_robot(rng, convention)
        Mlist, Glist, Slist = _modern_robotics_model(robot)
        g = rng.normal(size=3) * 5
        for _ in range(3):
            q, qd, qdd = (rng.uniform(-1.5, 1.5, robot.n) for _ in range(3))
            ref = mr.InverseDynamics(q, qd, qdd, g, np.zeros(6), Mlist, Glist, Slist)
            assert _rel(D.inverse_dynamics(robot, q, qd, qdd, gravity=g), ref) < REL
            M = mr.MassMatrix(q, Mlist, Glist, Slist)
            assert _rel(D.mass_matrix(robot, q), M) < REL
            h = mr.VelQuadraticForces(q, qd, Mlist, Glist, Slist)  # 0 for an all-prismatic chain
            assert _rel(D.coriolis_matrix(robot, q, qd) @ qd, h, np.abs(M).max() * float(qd @ qd)) < REL


def _pinocchio_check(path, robot, rng, lock=()):
    pin = require("pinocchio")
    model = pin.buildModelFromUrdf(str(path))
    if lock:
        ids = [model.getJointId(name) for name in lock]
        model = pin.buildReducedModel(model, ids, pin.neutral(model))
    assert [model.names[i] for i in range(1, model.njoints)] == list(robot.joint_names)
    data = model.createData()
    for _ in range(4):
        q, qd, qdd = (rng.uniform(-1.2, 1.2, robot.n) for _ in range(3))
        assert _rel(D.inverse_dynamics(robot, q, qd, qdd), pin.rnea(model, data, q, qd, qdd)) < REL
        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        assert _rel(D.mass_matrix(robot, q), M) < REL


def _kuka_urdfs():
    rtbdata = require("rtbdata")
    root = Path(rtbdata.__file__).parent / "xacro"
    return sorted(p for p in root.rglob("kr*.urdf"))


def test_pinocchio_on_rtb_data_urdfs():
    paths = _kuka_urdfs()
    assert {p.name for p in paths} >= {"kr210l150.urdf", "kr16_2.urdf"}
    rng = np.random.default_rng(5)
    for path in paths:
        _pinocchio_check(path, Robot.from_urdf(path), rng)


def _origin(rng, scale=0.3):
    xyz = " ".join(f"{v:.6f}" for v in rng.uniform(-scale, scale, 3))
    rpy = " ".join(f"{v:.6f}" for v in rng.uniform(-np.pi, np.pi, 3))
    return f'<origin xyz="{xyz}" rpy="{rpy}"/>'


def _inertial_xml(rng):
    A = rng.normal(size=(3, 3)) * 0.05
    I = A @ A.T + 1e-3 * np.eye(3)
    return (f'<inertial>{_origin(rng, 0.1)}<mass value="{rng.uniform(0.2, 3):.6f}"/>'
            f'<inertia ixx="{I[0, 0]:.9f}" ixy="{I[0, 1]:.9f}" ixz="{I[0, 2]:.9f}" iyy="{I[1, 1]:.9f}" '
            f'iyz="{I[1, 2]:.9f}" izz="{I[2, 2]:.9f}"/></inertial>')


def _generated_urdf(rng, n):
    """A chain of n moving joints with fixed links between and after them, a fixed side branch
    and a moving side branch (a finger) off link 2."""
    parts, links, parent = [], ['<link name="base"/>'], "base"
    for i in range(1, n + 1):
        if rng.random() < 0.5:  # a fixed link before the moving joint
            links.append(f'<link name="spacer{i}">{_inertial_xml(rng)}</link>')
            parts.append(f'<joint name="fix{i}" type="fixed"><parent link="{parent}"/><child link="spacer{i}"/>'
                         f'{_origin(rng)}</joint>')
            parent = f"spacer{i}"
        kind = "prismatic" if rng.random() < 0.25 else "revolute"
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        links.append(f'<link name="link{i}">{_inertial_xml(rng)}</link>')
        parts.append(f'<joint name="j{i}" type="{kind}"><parent link="{parent}"/><child link="link{i}"/>'
                     f'{_origin(rng)}<axis xyz="{axis[0]:.9f} {axis[1]:.9f} {axis[2]:.9f}"/>'
                     '<limit lower="-2" upper="2" effort="10" velocity="3"/></joint>')
        parent = f"link{i}"
    links += [f'<link name="flange">{_inertial_xml(rng)}</link>', f'<link name="tool">{_inertial_xml(rng)}</link>',
              f'<link name="sensor">{_inertial_xml(rng)}</link>', f'<link name="finger">{_inertial_xml(rng)}</link>']
    parts += [f'<joint name="f1" type="fixed"><parent link="{parent}"/><child link="flange"/>{_origin(rng)}</joint>',
              f'<joint name="f2" type="fixed"><parent link="flange"/><child link="tool"/>{_origin(rng)}</joint>',
              f'<joint name="f3" type="fixed"><parent link="link2"/><child link="sensor"/>{_origin(rng)}</joint>',
              f'<joint name="finger_joint" type="prismatic"><parent link="link2"/><child link="finger"/>{_origin(rng)}'
              '<axis xyz="0 0 1"/><limit lower="0" upper="0.04" effort="10" velocity="1"/></joint>']
    return f'<robot name="gen">{"".join(links)}{"".join(parts)}</robot>'


def test_pinocchio_on_urdfs_with_fixed_joints_and_branches(tmp_path):
    rng = np.random.default_rng(35)
    for k in range(6):
        n = int(rng.integers(3, 7))
        path = tmp_path / f"gen{k}.urdf"
        path.write_text(_generated_urdf(rng, n))
        robot = Robot.from_urdf(path, base_link="base", tip_link="tool")
        assert robot.n == n
        _pinocchio_check(path, robot, rng, lock=("finger_joint",))


def _random_rtb_robot(rtb, SE3, rng, modified):
    """A random roboticstoolbox DHRobot built from its own DH rows: prismatic joints, motors with friction, a
    rotated base and tool (no flipped joints: roboticstoolbox's ``rne`` ignores ``flip``, checked below)."""
    links = []
    for _ in range(int(rng.integers(2, 7))):
        A = rng.normal(size=(3, 3)) * 0.05
        kw = dict(a=rng.uniform(-0.5, 0.5), alpha=float(rng.choice([0.0, np.pi / 2, -np.pi / 2, rng.uniform(-3, 3)])),
                  m=rng.uniform(0.2, 3.0), r=rng.uniform(-0.2, 0.2, 3), I=A @ A.T + 1e-3 * np.eye(3),
                  Jm=rng.uniform(0, 1e-3), G=rng.uniform(-80, 80), B=rng.uniform(0, 1e-3),
                  Tc=[rng.uniform(0, 0.3), -rng.uniform(0, 0.3)])
        if rng.random() < 0.3:
            kind = rtb.PrismaticMDH if modified else rtb.PrismaticDH
            links.append(kind(theta=rng.uniform(-3, 3), offset=rng.uniform(-0.3, 0.3), qlim=[-1, 1], **kw))
        else:
            kind = rtb.RevoluteMDH if modified else rtb.RevoluteDH
            links.append(kind(d=rng.uniform(-0.5, 0.5), offset=rng.uniform(-3, 3), qlim=[-3, 3], **kw))
    base = SE3.Rx(rng.uniform(-3, 3)) * SE3.Ry(rng.uniform(-3, 3)) * SE3(*rng.uniform(-0.3, 0.3, 3))
    tool = SE3.Rz(rng.uniform(-3, 3)) * SE3(*rng.uniform(-0.1, 0.1, 3))
    return rtb.DHRobot(links, base=base, tool=tool, gravity=rng.normal(size=3) * 5, name="random")


@pytest.mark.parametrize("modified", [False, True], ids=["standard", "modified"])
def test_random_dh_robots_built_in_roboticstoolbox(modified):
    """Independent of labkit's frames: the robot is built in roboticstoolbox from DH rows (both conventions) and
    converted field by field; its Python ``rne`` (the compiled one is wrong for a prismatic joint after a rotated
    base, see C_RNE_WRONG) drives ``inertia``, ``coriolis``, ``gravload`` and ``accel``."""
    rtb = require("roboticstoolbox")
    from spatialmath import SE3

    rng = np.random.default_rng(3839 + modified)
    for _ in range(6):
        model = _random_rtb_robot(rtb, SE3, rng, modified)
        model.rne = model.rne_python
        robot = _from_rtb(model)
        assert robot.convention is (Convention.MODIFIED if modified else Convention.STANDARD)
        g = np.asarray(model.gravity, dtype=float)
        q, qd, qdd = (rng.uniform(-1.5, 1.5, size=(3, robot.n)) for _ in range(3))
        tau, M = D.inverse_dynamics(robot, q, qd, qdd, gravity=g), D.mass_matrix(robot, q)
        C, G = D.coriolis_matrix(robot, q, qd), D.gravity_torques(robot, q, gravity=g)
        torque = rng.uniform(-20, 20, size=(3, robot.n))
        acc = D.forward_dynamics(robot, q, qd, torque, gravity=g)
        for k in range(len(q)):
            assert _rel(tau[k], model.rne(q[k], qd[k], qdd[k], gravity=g)) < REL
            assert _rel(M[k], model.inertia(q[k])) < REL
            if not (modified and not model.links[0].isrevolute):  # see the next test
                assert _rel(C[k], model.coriolis(q[k], qd[k])) < REL
            assert _rel(C[k], _christoffel(model, q[k], qd[k])) < 1e-6  # central differences of rtb's inertia
            assert _rel(G[k], model.gravload(q[k], gravity=g)) < REL
            assert _rel(acc[k], model.accel(q[k], qd[k], torque[k], gravity=g)) < REL


def _christoffel(model, q, qd, h=1e-6):
    """``C[i, j] = sum_k Gamma_ijk qd_k`` from central differences of roboticstoolbox's ``inertia``."""
    dM = np.array([(model.inertia(q + h * e) - model.inertia(q - h * e)) / (2 * h) for e in np.eye(model.n)])  # k, i, j
    gamma = 0.5 * (np.einsum("kij->ijk", dM) + np.einsum("jik->ijk", dM) - np.einsum("ijk->ijk", dM))
    return gamma @ qd


def test_roboticstoolbox_coriolis_is_off_for_a_modified_dh_arm_whose_first_joint_slides():
    """Finding: roboticstoolbox 1.5's ``coriolis`` of a modified-DH arm with a prismatic first joint is not the
    Christoffel matrix of its own ``inertia`` (its standard-DH twin and other joint orders are); labkit's is."""
    rtb = require("roboticstoolbox")
    rng = np.random.default_rng(1)
    links = [rtb.PrismaticMDH(theta=0.4, qlim=[-1, 1], a=0.2, alpha=0.7, m=1.0, r=[0.05, 0.02, -0.03],
                              I=np.diag([2e-3, 3e-3, 4e-3]))]
    links += [rtb.RevoluteMDH(d=0.1, a=0.2, alpha=0.7, m=1.0, r=[0.05, 0.02, -0.03], I=np.diag([2e-3, 3e-3, 4e-3]))
              for _ in range(2)]
    model = rtb.DHRobot(links)
    model.rne = model.rne_python
    q, qd = rng.uniform(-1, 1, 3), rng.uniform(-1, 1, 3)
    truth = _christoffel(model, q, qd)
    assert _rel(model.coriolis(q, qd), truth) > 1e-3
    assert _rel(D.coriolis_matrix(_from_rtb(model), q, qd), truth) < 1e-6


def test_roboticstoolbox_rne_ignores_a_flipped_joint_which_labkit_runs_backwards():
    """Why no flipped joint is compared with roboticstoolbox: its kinematics turns a flipped joint backwards
    (``fkine(q)`` of the flipped arm is ``fkine(-q)`` of the plain one) but its ``rne`` does not; labkit's
    dynamics of the flipped arm are the plain arm's run backwards, as its kinematics."""
    rtb = require("roboticstoolbox")

    def arm(flip):
        return rtb.DHRobot([rtb.RevoluteDH(a=0.3, alpha=0.4, m=1.0, r=[0.1, 0.05, 0.0], I=np.eye(3) * 1e-2, flip=flip)
                            for _ in range(2)])

    plain, flipped = arm(False), arm(True)
    q, qd, qdd = np.array([0.3, -0.7]), np.array([0.5, 0.2]), np.array([0.1, -0.3])
    assert np.allclose(flipped.fkine(q).A, plain.fkine(-q).A)
    backwards = -plain.rne_python(-q, -qd, -qdd)
    assert _rel(flipped.rne_python(q, qd, qdd), backwards) > 0.1  # roboticstoolbox: not the plain arm backwards
    assert _rel(D.inverse_dynamics(_from_rtb(flipped), q, qd, qdd, gravity=plain.gravity), backwards) < REL
