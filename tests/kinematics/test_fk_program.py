"""The one DH recursion (``labkit.kinematics._program.walk``) on both of its evaluators.

Every FK quantity is a program compiled from the one walk; a handful of
configurations runs it as generated Python code on floats, a bigger batch as
numpy ufunc calls. Both are checked against an independent reference: the
textbook product of 4 x 4 DH matrices written out here, and central
differences of FK for the Jacobian. Random robots of both conventions with
prismatic and flipped joints, offsets, base and tool transforms.
"""

import numpy as np
import pytest

from labkit.exceptions import ShapeError
from labkit.kinematics import _program, fk, fk_frames, fk_jacobian, fk_position, jacobian
from labkit.kinematics._chain import chain
from labkit.kinematics._forward import SMALL_BATCH
from labkit.robot import Convention, JointType, Link, Robot
from labkit.rotations import matrix_from_rpy

#: batch sizes that take each evaluator: Python floats, numpy rows
EVALUATORS = {"floats": SMALL_BATCH, "numpy": 3 * SMALL_BATCH + 1}


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
            flip=bool(rng.random() < 0.3),
        ))
    extra = {}
    if moved:
        for name in ("base", "tool"):
            T = np.eye(4)
            T[:3, :3] = matrix_from_rpy(rng.uniform(-np.pi, np.pi, 3))
            T[:3, 3] = rng.uniform(-0.3, 0.3, 3)
            extra[name] = T
    return Robot(name="random", links=tuple(links), convention=convention, **extra)


def _reference_frames(robot, q):
    """Textbook DH: base @ A_1 @ ... @ A_n @ tool, one configuration, every frame."""
    def rz(t):
        return np.array([[np.cos(t), -np.sin(t), 0, 0], [np.sin(t), np.cos(t), 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])

    def rx(t):
        return np.array([[1, 0, 0, 0], [0, np.cos(t), -np.sin(t), 0], [0, np.sin(t), np.cos(t), 0], [0, 0, 0, 1]])

    def tr(x, z):
        T = np.eye(4)
        T[0, 3], T[2, 3] = x, z
        return T

    T = robot.base.copy()
    frames = [T]
    for lk, qi in zip(robot.links, q):
        v = -qi if lk.flip else qi
        theta, d = (lk.theta + v, lk.d) if lk.is_revolute else (lk.theta, lk.d + v)
        if robot.convention is Convention.STANDARD:
            A = rz(theta) @ tr(0, d) @ tr(lk.a, 0) @ rx(lk.alpha)
        else:
            A = rx(lk.alpha) @ tr(lk.a, 0) @ rz(theta) @ tr(0, d)
        T = T @ A
        frames.append(T)
    frames.append(T @ robot.tool)
    return np.array(frames)


CASES = [(conv, n, moved) for conv in Convention for n in (1, 3, 6, 7) for moved in (False, True)]


@pytest.mark.parametrize("evaluator", sorted(EVALUATORS))
@pytest.mark.parametrize("convention,n,moved", CASES)
def test_fk_frames_and_position_equal_the_textbook_product(evaluator, convention, n, moved):
    rng = np.random.default_rng(CASES.index((convention, n, moved)))
    robot = _robot(rng, convention, n, moved)
    q = rng.uniform(-3.0, 3.0, size=(EVALUATORS[evaluator], n))
    ref = np.array([_reference_frames(robot, qk) for qk in q])
    np.testing.assert_allclose(fk_frames(robot, q), ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fk(robot, q), ref[:, -1], rtol=0, atol=1e-12)
    np.testing.assert_allclose(fk_position(robot, q), ref[:, -1, :3, 3], rtol=0, atol=1e-12)
    point = np.array([0.1, -0.2, 0.05])
    np.testing.assert_allclose(fk_position(robot, q, point), (ref[:, -1, :3, :3] @ point) + ref[:, -1, :3, 3],
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(fk(robot, q[0]), ref[0, -1], rtol=0, atol=1e-12)  # one configuration


@pytest.mark.parametrize("evaluator", sorted(EVALUATORS))
@pytest.mark.parametrize("convention", list(Convention))
def test_jacobian_matches_finite_differences_of_fk(evaluator, convention):
    rng = np.random.default_rng(5 + len(convention.value))
    robot = _robot(rng, convention, 6, True)
    q = rng.uniform(-3.0, 3.0, size=(EVALUATORS[evaluator], 6))
    point = np.array([0.02, 0.0, 0.1])
    T, J = fk_jacobian(robot, q, point=point)
    np.testing.assert_array_equal(J, jacobian(robot, q, point=point))
    h = 1e-6
    for i in range(6):
        dq = np.zeros(6)
        dq[i] = h
        Tp, Tm = fk(robot, q + dq), fk(robot, q - dq)
        v = (Tp[:, :3, :3] @ point + Tp[:, :3, 3] - Tm[:, :3, :3] @ point - Tm[:, :3, 3]) / (2 * h)
        W = (Tp[:, :3, :3] - Tm[:, :3, :3]) / (2 * h) @ np.swapaxes(T[:, :3, :3], 1, 2)  # skew(omega)
        w = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], axis=1)
        np.testing.assert_allclose(J[:, :3, i], v, atol=1e-7)
        np.testing.assert_allclose(J[:, 3:, i], w, atol=1e-7)
    # the pose of fk_jacobian is the point's; the tool-frame Jacobian is R^T J
    np.testing.assert_allclose(T[:, :3, 3], fk_position(robot, q, point), rtol=0, atol=1e-12)
    Jt = jacobian(robot, q, point=point, frame="tool")
    Rt = np.swapaxes(T[:, :3, :3], 1, 2)
    np.testing.assert_allclose(Jt[:, :3], Rt @ J[:, :3], rtol=0, atol=1e-12)
    np.testing.assert_allclose(Jt[:, 3:], Rt @ J[:, 3:], rtol=0, atol=1e-12)


def test_out_is_written_and_returned():
    puma = Robot.load("puma560")
    for shape in ((2, 3), (40, 30)):
        q = np.random.default_rng(1).uniform(-1, 1, shape + (6,))
        out = np.full(shape + (4, 4), np.nan)
        assert fk(puma, q, out=out) is out
        np.testing.assert_array_equal(out, fk(puma, q))
        J = np.full(shape + (6, 6), np.nan)
        T = np.full(shape + (4, 4), np.nan)
        Tr, Jr = fk_jacobian(puma, q, out=(T, J))
        assert Tr is T and Jr is J
        np.testing.assert_array_equal(J, jacobian(puma, q))
        np.testing.assert_allclose(T, out, rtol=0, atol=1e-15)
        p = np.empty(shape + (3,))
        assert fk_position(puma, q, out=p) is p
        np.testing.assert_allclose(p, out[..., :3, 3], rtol=0, atol=1e-15)


def test_bad_out_and_bad_input_are_rejected():
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
    arm = Robot.load("arduino_arm_3dof")
    for bad in ([0.1, np.nan, 0.0], np.array([[0.1, 0.2, np.inf]])):
        with pytest.raises(ShapeError, match="expected finite q"):
            fk(arm, bad)
        with pytest.raises(ShapeError, match="expected finite q"):
            jacobian(arm, bad)
    with pytest.raises(ShapeError, match=r"expected q with shape \(\.\.\., 3\), got \(2,\)"):
        fk_position(arm, [0.1, 0.2])
    np.testing.assert_array_equal(fk(arm, [0, 1, 1]), fk(arm, np.array([0.0, 1.0, 1.0])))


def test_puma_program_folds_the_constant_work():
    """The PUMA 560's Jacobian program: about 120 calls, each output row written exactly once."""
    prog = _program.program(chain(Robot.load("puma560")), _program.JACOBIAN)
    assert prog.n_rows == 36 and len(prog.ops) <= 130 and prog.n_scratch <= 20
    first, stop = prog.n_inputs, prog.n_inputs + prog.n_rows  # output rows in the bind() list
    written = [o - first for _, _, _, o in prog.ops if first <= o < stop]
    constant = [row for row, _ in prog.constants]
    assert sorted(written + constant) == list(range(36))
    # J[:, 0] of the PUMA: axis 1 is z0 = (0, 0, 1), so J[2, 0] = wx = wy = 0, wz = 1 are constants
    assert {(row, value) for row, value in prog.constants} >= {(2 * 6, 0.0), (3 * 6, 0.0), (4 * 6, 0.0),
                                                               (5 * 6, 1.0)}
    # the float code is generated from the same operations
    assert prog.scalar() is prog.scalar()


def test_program_cache_is_keyed_by_structure_and_options_and_bounded():
    c = chain(Robot.load("arduino_arm_3dof"))
    a = _program.program(c, _program.JACOBIAN)
    assert _program.program(c, _program.JACOBIAN).program is a.program
    assert _program.program(chain(Robot.load("arduino_arm_3dof")), _program.JACOBIAN).program is a.program
    assert _program.program(c, _program.JACOBIAN, None, True, False).program is not a.program
    assert _program.program(c, _program.JACOBIAN, np.array([0.0, 0.0, 0.1]), False, True).n_rows == 18 + 16
    for k in range(3 * _program._MAX_PROGRAMS):  # structures: where the zeros are
        _program.program(c, _program.POSITION, np.array([0.0, 0.0, 0.01]) * [k % 2, k % 3, 1 + k])
    assert len(_program._PROGRAMS) <= _program._MAX_PROGRAMS


def _counting_builds(monkeypatch):
    """A list that grows by the output of every program compiled from now on."""
    builds, build = [], _program._build
    monkeypatch.setattr(_program, "_build", lambda c, *args: builds.append(args[2]) or build(c, *args))
    monkeypatch.setattr(_program, "_PROGRAMS", {})  # (a cache filled by other tests could be cleared mid-test)
    return builds


def test_fresh_robots_and_copies_with_other_numbers_compile_nothing(monkeypatch):
    """Programs depend on a robot's structure, its numbers are inputs: a freshly loaded robot or a copy with
    other lengths reuses them, and still computes its own kinematics."""
    from labkit.kinematics import ik, ik_numeric

    builds = _counting_builds(monkeypatch)
    rng = np.random.default_rng(4)
    for name in ("arduino_arm_3dof", "puma560"):
        first = Robot.load(name)
        bent = first.with_link(first.n - 2, a=0.002)  # (a new structure: a zero length becomes a number)
        for robot in (first, bent):
            q = rng.uniform(*robot.joint_limits.T, size=(3, robot.n))
            fk(robot, q[0]), fk(robot, q), jacobian(robot, q[0]), fk_jacobian(robot, q), fk_position(robot, q[0])
            fk_frames(robot, q)  # (as IK's family detection does, unless it knows the robot's content)
            T = fk(robot, q[0])
            target = T[:3, 3] if robot.n == 3 else T
            ik(robot, target), ik_numeric(robot, target)
        compiled = len(builds)
        assert compiled > 0
        longer = first
        for i, link in enumerate(first.links):  # every length 1 % longer (the zeros stay zeros)
            longer = longer.with_link(i, a=1.01 * link.a, d=1.01 * link.d)
        for robot in (Robot.load(name), longer, bent.with_link(first.n - 2, a=-0.003)):
            q = rng.uniform(*robot.joint_limits.T, size=(20, robot.n))
            for k in (0, 7):
                assert np.abs(fk(robot, q[k]) - _reference_frames(robot, q[k])[-1]).max() < 1e-12
            jacobian(robot, q[0]), fk_jacobian(robot, q), fk_position(robot, q[0])
            T = fk(robot, q[0])
            target = T[:3, 3] if robot.n == 3 else T
            ik(robot, target), ik_numeric(robot, target)
        assert len(builds) == compiled, builds[compiled:]


def test_calibration_compiles_a_few_programs_not_one_per_residual(monkeypatch):
    from labkit.data import measurement_file
    from labkit.measure import calibrate

    arm = Robot.load("arduino_arm_3dof")
    builds = _counting_builds(monkeypatch)
    calibrate(measurement_file("seed000_fk_tables1-3.csv"), arm, params=("joint_offsets", "link_lengths"))
    first = len(builds)
    assert first <= 8  # a few structures (offsets 0 or not; frames, positions), not one per residual (hundreds)
    calibrate(measurement_file("seed000_fk_tables1-3.csv"), Robot.load("arduino_arm_3dof"), params=("joint_offsets",))
    assert len(builds) == first
