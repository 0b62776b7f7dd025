"""labkit works from a built wheel: bundled robots, seed tables and report assets come along."""

import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_wheel_carries_data_and_runs_outside_the_checkout(tmp_path):
    subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", str(REPO), "-w", str(tmp_path)],
                   check=True, capture_output=True)
    (wheel,) = tmp_path.glob("labkit-*.whl")
    site = tmp_path / "site"
    zipfile.ZipFile(wheel).extractall(site)
    code = (
        "import labkit, labkit.data as d, labkit.reports._render as r\n"
        "from labkit.robot import Robot, bundled_robots\n"
        "from labkit.measure import load_measurements\n"
        f"assert labkit.__file__.startswith({str(site)!r}), labkit.__file__\n"
        "assert {'arduino_arm_3dof', 'puma560'} <= set(bundled_robots())\n"
        "assert Robot.load('puma560').n == 6\n"
        "assert len(load_measurements(d.measurement_file('seed000_ik_table4.csv'))) > 0\n"
        "assert (r.TEMPLATES / 'labkit_report' / 'index.html.j2').is_file()\n"
        "assert (r.STATIC / 'mathjax-tex-svg-full.js.gz').is_file()\n"
        "from labkit.labs import new_lab\n"
        "lab = new_lab('lab', 'planar3r_seed003')\n"  # the lab templates ship in the wheel
        "assert len(lab.notebooks) == 6, lab\n"
        "print('ok')\n"
    )
    run = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True,
                         env={"PYTHONPATH": str(site), "PATH": "/usr/bin:/bin"})
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "ok"
