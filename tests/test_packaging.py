"""labkit works from a built wheel: bundled robots, seed tables and report assets come along."""

import re
import subprocess
import sys
import tomllib
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
        "assert len(lab.notebooks) == 7, lab\n"
        "print('ok')\n"
    )
    run = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True,
                         env={"PYTHONPATH": str(site), "PATH": "/usr/bin:/bin"})
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "ok"


PYPROJECT = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["project"]


def _normalised(name):
    return re.sub(r"[-_.]+", "-", name).lower()


def _distributions(requirements, extras=PYPROJECT["optional-dependencies"]):
    """Normalised names of the distributions ``requirements`` bring, with what their requested extras add:
    ``labkit[reports]`` expands to the reports extra, ``dask[distributed]`` adds the distribution "distributed"."""
    import importlib.metadata as md

    from packaging.requirements import Requirement

    declared = set()
    for r in map(Requirement, requirements):
        if _normalised(r.name) == "labkit":
            for extra in r.extras:
                declared |= _distributions(extras[extra])
            continue
        declared.add(_normalised(r.name))
        for extra in r.extras:
            for sub in map(Requirement, md.requires(r.name) or []):
                if sub.marker is not None and "extra" in str(sub.marker) and sub.marker.evaluate({"extra": extra}):
                    declared.add(_normalised(sub.name))
    return declared


CORE = _distributions(PYPROJECT["dependencies"])
EXTRA_DISTRIBUTIONS = {name: _distributions(reqs) for name, reqs in PYPROJECT["optional-dependencies"].items()}


def _imports_with_their_extra():
    """Every third-party import in labkit's code: (top-level module, file:line, extra), where extra is the
    ``needs_extra(NAME)`` block around the import, "optional" inside a ``try`` that handles its absence, or None."""
    import ast

    found = []

    def visit(node, path, extra):
        for child in ast.iter_child_nodes(node):
            inner = extra
            if isinstance(child, ast.With):
                for item in child.items:
                    call = item.context_expr
                    if isinstance(call, ast.Call) and getattr(call.func, "id", None) == "needs_extra":
                        inner = call.args[0].value
            elif isinstance(child, ast.Try) and any(
                    h.type is not None and {"ImportError", "ModuleNotFoundError", "Exception"} & {
                        n.id for n in ast.walk(h.type) if isinstance(n, ast.Name)} for h in child.handlers):
                inner = extra or "optional"
            if isinstance(child, ast.Import):
                names = [alias.name for alias in child.names]
            elif isinstance(child, ast.ImportFrom) and child.level == 0 and child.module:
                names = [child.module]
            else:
                names = []
            for name in names:
                top = name.split(".")[0]
                if top != "labkit" and top not in sys.stdlib_module_names:
                    found.append((top, f"{path.relative_to(REPO)}:{child.lineno}", inner))
            visit(child, path, inner)

    for path in sorted((REPO / "labkit").rglob("*.py")):
        visit(ast.parse(path.read_text(encoding="utf-8")), path, None)
    return found


def test_every_import_is_declared_by_the_core_or_by_the_extra_that_guards_it():
    """`pip install labkit` (the core) brings every module labkit imports outside a ``needs_extra`` block; an
    import inside ``with needs_extra("vision")`` comes from a distribution that pyproject.toml's ``vision`` extra
    declares, so a missing module names the right `pip install 'labkit[vision]'` (never a bare
    ModuleNotFoundError). Declared means named in pyproject.toml itself, not only brought by another package."""
    import importlib.metadata as md

    dist_of = md.packages_distributions()
    imports = _imports_with_their_extra()
    assert {"numpy", "pypdf", "yaml", "cv2"} <= {top for top, _, _ in imports}  # imports inside functions too
    assert ("tomlkit", "bus") in {(top, extra) for top, _, extra in imports}  # calibrate-bus edits robot files
    assert {extra for _, _, extra in imports} >= {None, "optional", "reports", "vision", "course"}
    wrong = []
    for top, where, extra in imports:
        dists = {_normalised(d) for d in dist_of.get(top, [top])}
        allowed = (CORE if extra is None else
                   CORE.union(*EXTRA_DISTRIBUTIONS.values()) if extra == "optional" else
                   EXTRA_DISTRIBUTIONS.get(extra, set()))
        if not dists & allowed:
            wrong.append(f"{where}: {top} ({', '.join(sorted(dists))}) is not declared "
                         + ("by the core" if extra is None else f"by the {extra!r} extra"))
    assert not wrong, "\n".join(wrong)


def test_extras_in_the_code_are_the_extras_of_pyproject():
    """needs_extra's names are pyproject.toml's extras, [all] installs each, and the core stays light."""
    from labkit.exceptions import EXTRAS

    assert set(EXTRAS) <= set(EXTRA_DISTRIBUTIONS)
    assert EXTRA_DISTRIBUTIONS["all"] == set().union(*(EXTRA_DISTRIBUTIONS[e] for e in EXTRAS))
    heavy = {"jupyterlab", "opencv-contrib-python-headless", "pypandoc-binary", "nbgrader", "dask", "nbconvert",
             "ipykernel", "yourdfpy", "dynamixel-sdk"}
    assert not heavy & CORE, heavy & CORE


def test_labkit_imports_from_the_clones_parent_folder(tmp_path):
    """From the folder that holds the clone (a folder named ``labkit`` without ``__init__.py`` in the working
    directory: a namespace package to Python), `from labkit import Robot` still finds the real labkit. The
    Makefile's editable install puts the checkout on sys.path (editable_mode=compat) instead of an import hook
    that comes after the namespace package."""
    (tmp_path / "labkit").mkdir()
    run = subprocess.run([sys.executable, "-c", "from labkit import Robot, __file__ as f; print(f)"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.strip() == str(REPO / "labkit" / "__init__.py")
