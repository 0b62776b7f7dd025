"""Benchmarks of issue 3: a Cartesian line with IK at every sample, and a big workspace.

Run ``python benchmarks/bench_trajectory.py``. Prints best-of-N wall times and
the ratio to the targets of the issue; asserts nothing.

* 10,000-sample Cartesian line with IK for the 3-DOF Arduino arm (seed 000's
  move), target < 20 ms: the full :func:`labkit.motion.cartesian_trajectory`
  (time law, path, IK on one branch, joint rates and accelerations through the
  Jacobian, joint-limit check), and the IK part alone.
* 1,000,000-sample workspace of the same arm, target < 0.5 s
  (:func:`labkit.kinematics.workspace_points`, batched forward kinematics).
"""

from __future__ import annotations

import time

import numpy as np

from labkit.kinematics import ik, workspace_points
from labkit.motion import cartesian_trajectory, line
from labkit.robot import Robot


def best_of(fn, repeat=7):
    fn()  # warm-up (imports, caches)
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times), float(np.median(times))


def report(name, seconds, target):
    best, median = seconds
    print(f"{name:<58s} best {best * 1e3:8.2f} ms  median {median * 1e3:8.2f} ms  "
          f"target {target * 1e3:6.0f} ms  ratio {best / target:5.2f}")


def main():
    arm = Robot.load("arduino_arm_3dof")
    path = line([0.0, 0.18, -0.094], [0.1, 0.15, -0.2])
    t = np.linspace(0.0, 5.0, 10_000)

    traj = cartesian_trajectory(arm, path, 5.0, t=t, branch="elbow_up")
    assert traj.q.shape == (10_000, 3)
    report("Cartesian line, 10,000 samples, IK + qd/qdd (3-DOF arm)",
           best_of(lambda: cartesian_trajectory(arm, path, 5.0, t=t, branch="elbow_up")), 0.020)
    report("  of which: IK alone on the 10,000 points",
           best_of(lambda: ik(arm, traj.x.copy(), branch="elbow_up")), 0.020)

    report("Workspace, 1,000,000 samples (3-DOF arm)",
           best_of(lambda: workspace_points(arm, n=1_000_000), repeat=5), 0.5)


if __name__ == "__main__":
    main()
