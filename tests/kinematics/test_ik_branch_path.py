"""``ik(..., branch=...)`` on a batch solves the named branch alone and agrees with the full path.

For a ``yaw_pitch_pitch`` arm a batch with a named branch runs only that branch
(``_ik_analytic.solve_one_branch``); when a target is unreachable or out of
limits on it, the full four-branch path runs and raises. Forcing the full path
(the branch path answering None) must give the same solution to 1e-12, or the
same exception with the same message and attributes, on random arms (flipped
joints, offsets, wide limits) and targets.
"""

import numpy as np
import pytest

from labkit.kinematics import _ik_analytic, fk, ik, ik_all
from tests.kinematics.test_ik_small_path import _arms, _outcome, _same

ARMS = _arms()


def _full_path(monkeypatch, *args, **kwargs):
    with monkeypatch.context() as m:
        m.setattr(_ik_analytic, "solve_one_branch", lambda *a: None)
        return _outcome(ik, *args, **kwargs)


@pytest.mark.parametrize("name", sorted(ARMS))
def test_branch_path_equals_full_path(name, monkeypatch):
    robot = ARMS[name]
    rng = np.random.default_rng(40 + sorted(ARMS).index(name))
    lim = robot.joint_limits
    q = rng.uniform(np.maximum(lim[:, 0], -np.pi), np.minimum(lim[:, 1], np.pi), size=(300, 3))
    targets = fk(robot, q)[:, :3, 3]
    runs = []
    real = _ik_analytic.solve_one_branch
    monkeypatch.setattr(_ik_analytic, "solve_one_branch", lambda *a: runs.append(a[3]) or real(*a))
    sols = ik_all(robot, targets)
    outcomes = {"ok": 0, "fail": 0}
    for k, branch in enumerate(sols.branches):
        valid = sols.valid[:, k]
        far = targets.copy()
        far[17] *= 5.0  # one target out of reach
        # all valid on the branch; mixed and invalid ones (the full path raises); one out of reach
        for t in (targets[valid], targets, targets[~valid][:40], far[valid] if valid[17] else far):
            if len(t) <= 8:
                continue
            shaped = t.reshape(-1, 2, 3) if len(t) % 2 == 0 else t  # batch shapes are kept
            got = _outcome(ik, robot, shaped, branch=branch)
            _same(got, _full_path(monkeypatch, robot, shaped, branch=branch))
            outcomes["fail" if isinstance(got, Exception) else "ok"] += 1
        if valid.sum() > 8:
            np.testing.assert_allclose(ik(robot, targets[valid], branch=branch), sols.q[valid, k], rtol=0, atol=1e-12)
    assert outcomes["ok"] > 0 and outcomes["fail"] > 0
    assert runs  # the branch path ran


def test_branch_path_solution_is_the_ik_all_branch():
    robot = ARMS["arduino_wide_limits_flipped"]
    rng = np.random.default_rng(3)
    q = rng.uniform(-1.0, 1.0, size=(500, 3))
    targets = fk(robot, q)[:, :3, 3]
    sols = ik_all(robot, targets)
    for k, branch in enumerate(sols.branches):
        ok = sols.valid[:, k]
        if ok.sum() > 8:
            np.testing.assert_allclose(ik(robot, targets[ok], branch=branch), sols.q[ok, k], rtol=0, atol=1e-12)
            # and FK of the answer hits the targets
            np.testing.assert_allclose(fk(robot, sols.q[ok, k])[:, :3, 3], targets[ok], atol=1e-9)
