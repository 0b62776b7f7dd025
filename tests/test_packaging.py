"""labkit works from a built wheel: bundled robots, seed tables and report assets come along."""

import re
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
        "lab = new_lab('planar3r_seed003', 'lab')\n"  # the lab templates ship in the wheel
        "assert len(lab.notebooks) == 6, lab\n"
        "print('ok')\n"
    )
    run = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True,
                         env={"PYTHONPATH": str(site), "PATH": "/usr/bin:/bin"})
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "ok"


def _declared_distributions():
    """Normalised names of the core dependencies in pyproject.toml and of what their requested extras add."""
    import importlib.metadata as md
    import tomllib

    from packaging.requirements import Requirement

    deps = [Requirement(r) for r in tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["dependencies"]]
    declared = {_normalised(r.name) for r in deps}
    for r in deps:
        for extra in r.extras:  # e.g. dask[distributed] brings the distribution "distributed"
            for sub in map(Requirement, md.requires(r.name) or []):
                if sub.marker is not None and "extra" in str(sub.marker) and sub.marker.evaluate({"extra": extra}):
                    declared.add(_normalised(sub.name))
    return declared


def _normalised(name):
    return re.sub(r"[-_.]+", "-", name).lower()


def test_every_library_labkit_imports_is_a_core_dependency():
    """`pip install .` alone (the README's `make reports` in a fresh virtualenv) brings every third-party module
    that labkit's own code imports: each comes from a distribution that pyproject.toml's core dependencies name
    (not only from the test extras, nor only by way of another package)."""
    import ast
    import importlib.metadata as md

    dist_of = md.packages_distributions()
    imported = {}
    for path in sorted((REPO / "labkit").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            for name in names:
                top = name.split(".")[0]
                if top != "labkit" and top not in sys.stdlib_module_names:
                    imported.setdefault(top, str(path.relative_to(REPO)))
    assert {"numpy", "pypdf", "yaml", "cv2"} <= set(imported)  # the scan sees imports inside functions too
    declared = _declared_distributions()
    missing = {top: (where, dist_of.get(top)) for top, where in imported.items()
               if not {_normalised(d) for d in dist_of.get(top, [top])} & declared}
    assert not missing, f"imported by labkit but not a core dependency in pyproject.toml (module: file, distribution): {missing}"
