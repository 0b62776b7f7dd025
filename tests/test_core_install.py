"""`pip install labkit` without extras: a fresh virtualenv gets the light core, and the core does its job.

The core is what the library's math, motion, measurement tables, plots and the serial link need; the
test installs the checkout alone (no extras) in a new virtualenv, measures it as ``du -sm`` does (bytecode
caches included: pip writes them by default), runs FK, IK, a trajectory, an error table, a plot and a move on
the virtual arm there, and checks that two commands needing a missing extra name the `pip install` to run.
"""

import json
import os
import shutil
import subprocess
import sys
import venv
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

#: what the core venv may hold (issue 36: the full install was 1.3 GB, 158 distributions; target <= 45)
MAX_DISTRIBUTIONS = 45
#: what it may take on disk [MiB]: a guard against a heavy dependency slipping into the core, not the issue's
#: target. Issue 36 asks for <= 400 MB, which the core it names cannot reach: with Debian's python3.11 and the
#: newest wheels (numpy 2.4, scipy 1.17, pandas 3.1, matplotlib 3.11) numpy takes 72 MiB, scipy 142, pandas with
#: tzdata and dateutil 87, matplotlib with fonttools, pillow, kiwisolver, contourpy, pyparsing and packaging 103:
#: 403 MiB, the empty venv (pip, setuptools) 25 more, sympy with mpmath 84, python-control, pyserial, jinja2, tqdm
#: and labkit 15. Measured 531 MiB; the bound leaves room for the next releases of those wheels.
MAX_MEBIBYTES = 560

SMOKE = r"""
import importlib.util, json, os, sys
import numpy as np
import matplotlib
matplotlib.use("Agg")
from labkit import Robot
from labkit.arm import Arm
from labkit.data import measurement_file
from labkit.kinematics import fk, ik_all
from labkit.measure import error_table
from labkit.motion import joint_trajectory
from labkit.plotting import plot_arm, plot_trajectory

assert labkit_file_ok(), None
arm = Robot.load("arduino_arm_3dof")
q = np.radians([45.0, 60.0, 30.0])
T = fk(arm, q)
sols = ik_all(arm, T[:3, 3])
assert any(np.allclose(fk(arm, qi)[:3, 3], T[:3, 3], atol=1e-9) for qi in sols.q[sols.valid]), sols
traj = joint_trajectory(arm, np.zeros(3) + 0.5, q)
assert np.allclose(traj.q[-1], q) and traj.q.shape[1] == 3
errors = error_table(arm, measurement_file("seed000_fk_tables1-3.csv"))
assert "<table" in errors.to_html() and len(errors.table) > 0
ax = plot_arm(arm, q)
ax.figure.savefig("arm.png")
plot_trajectory(traj)[0].figure.savefig("trajectory.png")
with Arm(arm, "sim://") as link:
    link.move_joints(q, wait=True)
    reached = np.asarray(link.read_joints())
assert np.allclose(reached, q, atol=np.radians(3)), np.degrees(reached)
print(json.dumps({
    "extras_present": [m for m in ("nbformat", "nbconvert", "cv2", "jupyterlab", "nbgrader", "dynamixel_sdk",
                                   "yourdfpy", "psutil", "IPython") if importlib.util.find_spec(m)],
    "reached_deg": np.degrees(reached).round(2).tolist(),
}))
"""


def _disk_usage(root):
    """(MiB the venv takes on disk, MiB of that in bytecode caches), counted as ``du -sm`` counts: the blocks
    allocated to every file and folder, each inode once. The caches are what pip compiles at install (its default),
    so they belong to the install's size."""
    seen = set()
    total = caches = 0
    for dirpath, dirnames, names in os.walk(root):
        in_cache = "__pycache__" in Path(dirpath).parts
        for name in [".", *dirnames, *names]:
            st = os.lstat(os.path.join(dirpath, name))
            if (st.st_dev, st.st_ino) in seen:
                continue
            seen.add((st.st_dev, st.st_ino))
            total += st.st_blocks * 512
            caches += st.st_blocks * 512 if in_cache else 0
    return total / 2**20, caches / 2**20


@pytest.mark.slow
def test_core_install_is_light_and_runs_without_extras(tmp_path):
    env_dir = tmp_path / "core"
    venv.EnvBuilder(with_pip=True).create(env_dir)
    python = str(env_dir / "bin" / "python")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV", "PYTHONHOME")}
    env["PATH"] = f"{env_dir / 'bin'}:/usr/bin:/bin"
    source = tmp_path / "labkit-src"  # a copy: pip builds in the source tree, where another test builds a wheel too
    for name in ("pyproject.toml", "README.md"):
        source.mkdir(exist_ok=True)
        shutil.copy2(REPO / name, source / name)
    shutil.copytree(REPO / "labkit", source / "labkit", ignore=shutil.ignore_patterns("__pycache__"))
    subprocess.run([python, "-m", "pip", "install", "-q", str(source)], check=True, env=env, cwd=tmp_path,
                   capture_output=True, timeout=1800)
    count = int(subprocess.run([python, "-c", "import importlib.metadata as m; print(len({d.metadata['Name'].lower() "
                                "for d in m.distributions()}))"], check=True, env=env, capture_output=True,
                               text=True).stdout)
    mebibytes, caches = _disk_usage(env_dir)
    print(f"core venv: {mebibytes:.0f} MiB on disk (of which {caches:.0f} MiB bytecode caches), {count} distributions")
    assert mebibytes <= MAX_MEBIBYTES and count <= MAX_DISTRIBUTIONS, (mebibytes, caches, count)

    work = tmp_path / "work"
    work.mkdir()
    site = f"{env_dir}/lib/python{sys.version_info[0]}.{sys.version_info[1]}/site-packages/labkit"
    script = SMOKE.replace("labkit_file_ok()", f"__import__('labkit').__file__.startswith({site!r})")
    run = subprocess.run([python, "-c", script], env=env, cwd=work, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    result = json.loads(run.stdout.strip().splitlines()[-1])
    assert result["extras_present"] == [], result  # truly the core alone
    assert (work / "arm.png").stat().st_size > 1000 and (work / "trajectory.png").stat().st_size > 1000

    labkit = str(env_dir / "bin" / "labkit")
    for argv, extra in ((["render", "--no-pdf", str(REPO / "notebooks" / "servo_dynamics")], "reports"),
                        (["vision", "marker", "1", "-o", "tag.pdf"], "vision")):
        out = subprocess.run([labkit, *argv], env=env, cwd=work, capture_output=True, text=True, timeout=300)
        assert out.returncode == 2, (argv, out.returncode, out.stderr[-2000:])
        assert f"pip install 'labkit[{extra}]'" in out.stderr, (argv, out.stderr[-2000:])
        assert "Traceback" not in out.stderr, out.stderr
