"""A tiny tagged lab and simulated submissions for the course tests and the grading benchmark.

The lab (one notebook) asks for the x coordinate of the planar 3R arm's tool at
q = (0.1, 0.2, 0.3) rad; a public check tests that it is a finite number (1 point) and that
the notebook runs on ``sim://`` (a free row: it passes without student work); two hidden
checks test the value (an ``assert``) and the y coordinate (a ``Checks`` row).
"""

from pathlib import Path

NOTEBOOK = "01_fk.ipynb"
Q = [0.1, 0.2, 0.3]
SOLUTION = ("# Hint: labkit.kinematics.fk gives the tool pose; x is T[0, 3]\n"
            "T = fk(arm, q)\nx = float(T[0, 3])")
HIDDEN_1 = "expected = fk(arm, q)[0, 3]\nassert abs(x - expected) < 1e-9, (x, expected)  # SECRET-HIDDEN-MARKER"
HIDDEN_2 = ('checks.check("tool y [m]", T[1, 3], fk(arm, q)[1, 3], tol=1e-9, note="SECRET-HIDDEN-MARKER")\n'
            "checks.assert_all()")


def write_lab(folder: Path) -> Path:
    """Write the instructor's lab (solution and hidden tests) into ``folder``."""
    import nbformat

    cell = nbformat.v4.new_code_cell
    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    nb.cells = [
        nbformat.v4.new_markdown_cell("# Forward kinematics of the planar 3R arm (seed none)", id="intro"),
        cell('port = "serial:///dev/ttyACM0"\noutput_dir = "out"', id="params", metadata={"tags": ["parameters"]}),
        cell(f"import numpy as np\nfrom labkit.kinematics import fk\nfrom labkit.reports import Checks\n"
             f"from labkit.robot import Robot\narm = Robot.load('planar3r_seed004')\nq = np.array({Q})\n"
             f"checks = Checks('planar 3R FK')", id="setup"),
        cell(SOLUTION, id="work", metadata={"tags": ["solution"]}),
        cell("assert np.isfinite(x)\nassert port == 'sim://'", id="public",
             metadata={"tags": ["tests"], "labkit": {"check": "x is a number, on sim://", "points": 1}}),
        cell(HIDDEN_1, id="hidden-x", metadata={"tags": ["hidden-tests"], "labkit": {"check": "x value", "points": 2}}),
        cell(HIDDEN_2, id="hidden-y", metadata={"tags": ["hidden-tests"], "labkit": {"points": 1}}),
        nbformat.v4.new_markdown_cell("The end.", id="end"),
    ]
    folder.mkdir(parents=True, exist_ok=True)
    nbformat.write(nb, str(folder / NOTEBOOK))
    (folder / "data.txt").write_text("lab data\n")
    return folder


def write_submission(student_version: Path, folder: Path, code: str) -> Path:
    """A submission: the student version with the solution cell's code replaced by ``code``."""
    import nbformat

    nb = nbformat.read(str(student_version / NOTEBOOK), as_version=4)
    for c in nb.cells:
        if c.get("id") == "work":
            c.source = code
    folder.mkdir(parents=True, exist_ok=True)
    nbformat.write(nb, str(folder / NOTEBOOK))
    return folder


SUBMISSIONS = {
    "correct": SOLUTION,
    "partly_wrong": "T = fk(arm, q)\nx = float(T[0, 3]) + 0.01",
    "raising": "raise ValueError('I gave up')",
    "infinite_loop": "T = fk(arm, q)\nwhile True:\n    pass",
    "ten_gigabytes": "T = fk(arm, q)\nballast = bytearray(10 * 2**30)\nx = 1.0",
}
#: points expected per student: public (1: its "on sim://" row is free), hidden x value (2), hidden y (1)
EXPECTED = {"correct": (4, "ok"), "partly_wrong": (2, "ok"), "raising": (0, "error"),
            "infinite_loop": (0, "cpu-time"), "ten_gigabytes": (1, "memory")}
