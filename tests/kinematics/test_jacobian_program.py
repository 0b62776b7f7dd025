"""The compiled Jacobian programs (labkit.kinematics._program) agree with the generic walk.

From ``PROGRAM_BATCH_PER_CALL`` configurations per program call on, ``jacobian``,
``fk_jacobian`` and ``fk_position`` run a straight-line program specialised to the robot
(constants folded, signs carried, dead calls dropped); below that, the generic
walk on ``(3, m)`` blocks. Both paths are forced here on random robots of both
DH conventions with prismatic and flipped joints, theta offsets, base and tool
transforms, a tool point and both frames, with outputs written straight into
the result (one chunk or several) and through contiguous rows; they must agree
to 1e-12, and with finite differences of ``fk``.
"""

import dataclasses

import numpy as np
import pytest

from labkit.kinematics import _forward, _program, fk, fk_jacobian, fk_position, jacobian
from labkit.kinematics._chain import chain
from labkit.robot import Convention, Robot
from tests.kinematics.test_fk_paths import _robot


def _flipped(robot, rng):
    links = tuple(dataclasses.replace(lk, flip=bool(rng.random() < 0.4)) for lk in robot.links)
    return dataclasses.replace(robot, links=links)


CASES = [(conv, n, moved) for conv in Convention for n in (1, 2, 3, 6, 7) for moved in (False, True)]


@pytest.mark.parametrize("convention,n,moved", CASES)
def test_program_equals_generic_walk(convention, n, moved, monkeypatch):
    rng = np.random.default_rng(100 + CASES.index((convention, n, moved)))
    # small chunks, so that small batches exercise every mode: outputs written directly in one
    # chunk (100 configurations) or in several (700, position), through contiguous rows (700, J)
    monkeypatch.setattr(_forward, "_DIRECT_BATCH", 256)
    monkeypatch.setattr(_forward, "_DIRECT_ENTRIES", 100 * 6 * 7 + 16 * 100)
    monkeypatch.setattr(_forward, "_PROGRAM_CHUNK_ENTRIES", 0)  # chunks of 256
    for _ in range(3):
        robot = _flipped(_robot(rng, convention, n, moved), rng)
        for N in (100, 700):
            q = rng.uniform(-4.0, 4.0, size=(N, n))
            point = rng.uniform(-0.2, 0.2, 3)
            results = {}
            for per_call in (0, float("inf")):  # program always, then never
                monkeypatch.setattr(_forward, "PROGRAM_BATCH_PER_CALL", per_call)
                results[per_call] = [fk_jacobian(robot, q, point=pt, frame=fr)
                                     for pt in (None, point) for fr in ("base", "tool")]
                results[per_call].append((None, jacobian(robot, q)))
                results[per_call] += [(fk_position(robot, q, pt), fk_position(robot, q[::-1], pt))
                                      for pt in (None, point)]
            for (Tp, Jp), (Tw, Jw) in zip(results[0], results[float("inf")]):
                np.testing.assert_allclose(Jp, Jw, rtol=0, atol=1e-12)
                if Tw is not None:
                    np.testing.assert_allclose(Tp, Tw, rtol=0, atol=1e-12)


def test_program_jacobian_matches_finite_differences_of_fk():
    """Independent of both kernels: columns of J from central differences of fk (position and rotation)."""
    rng = np.random.default_rng(5)
    for convention in Convention:
        robot = _flipped(_robot(rng, convention, 6, True), rng)
        q = rng.uniform(-3.0, 3.0, size=(500, 6))  # program path (500 >= 2 x calls)
        assert 500 >= _forward.PROGRAM_BATCH_PER_CALL * len(_program.program(chain(robot), None, False, False).ops)
        J = jacobian(robot, q)
        T = fk(robot, q)
        h = 1e-6
        for i in range(6):
            dq = np.zeros(6)
            dq[i] = h
            Tp, Tm = fk(robot, q + dq), fk(robot, q - dq)
            v = (Tp[:, :3, 3] - Tm[:, :3, 3]) / (2 * h)
            dR = (Tp[:, :3, :3] - Tm[:, :3, :3]) / (2 * h)
            W = dR @ np.swapaxes(T[:, :3, :3], 1, 2)  # skew(omega)
            w = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], axis=1)
            np.testing.assert_allclose(J[:, :3, i], v, atol=1e-7)
            np.testing.assert_allclose(J[:, 3:, i], w, atol=1e-7)


def test_puma_program_folds_the_constant_work():
    """The PUMA 560's Jacobian program: about 120 calls, each output row written exactly once."""
    prog = _program.program(chain(Robot.load("puma560")), None, False, False)
    assert prog.n_rows == 36 and len(prog.ops) <= 130 and prog.n_scratch <= 20
    first, stop = prog.n_inputs, prog.n_inputs + prog.n_rows  # output rows in the bind() list
    written = [o - first for _, _, _, o in prog.ops if first <= o < stop]
    constant = [row for row, _ in prog.constants]
    assert sorted(written + constant) == list(range(36))
    # J[:, 0] of the PUMA: axis 1 is z0 = (0, 0, 1), so J[2, 0] = wx = wy = 0, wz = 1 are constants
    assert {(row, value) for row, value in prog.constants} >= {(2 * 6, 0.0), (3 * 6, 0.0), (4 * 6, 0.0),
                                                               (5 * 6, 1.0)}


def test_program_cache_is_keyed_by_options_and_bounded():
    c = chain(Robot.load("arduino_arm_3dof"))
    a = _program.program(c, None, False, False)
    assert _program.program(c, None, False, False) is a
    assert _program.program(c, None, True, False) is not a
    assert _program.program(c, np.array([0.0, 0.0, 0.1]), False, True).n_rows == 18 + 16
    for k in range(3 * _program._MAX_PER_CHAIN):
        _program.program(c, np.array([0.0, 0.0, 0.01 * k]), False, False)
    assert len(_program._PROGRAMS[c]) <= _program._MAX_PER_CHAIN


def test_out_and_batch_shapes_on_the_program_path():
    puma = Robot.load("puma560")
    q = np.random.default_rng(2).uniform(-2, 2, (40, 30, 6))  # 1200 configurations
    J = np.full((40, 30, 6, 6), np.nan)
    T = np.full((40, 30, 4, 4), np.nan)
    Tr, Jr = fk_jacobian(puma, q, out=(T, J))
    assert Tr is T and Jr is J
    np.testing.assert_array_equal(J[7, 11], jacobian(puma, q[7, 11]))
    np.testing.assert_array_equal(T[:, :, 3], np.broadcast_to([0.0, 0.0, 0.0, 1.0], (40, 30, 4)))
    np.testing.assert_allclose(T, fk(puma, q), rtol=0, atol=1e-15)
