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


# A lab with a derivation row and no reference cell (the way a lab is first written): the lab's own cell computes
# q = IK(target) and its frames in the student's kernel; the student derives the steps; the public check compares
# the steps with that q and proves q by FK(q) - target (target: the trusted parameters cell), a row that passes on
# the untouched version; the hidden check compares the wrist point with the lab's frames (computed from q).
IK_NOTEBOOK = "01_ik.ipynb"
IK_SOLUTION = ("# Hint: the wrist point (x3, y3), cos_t2 by the cosine law, t2 <= 0 (elbow minus), then t1 and t3\n"
               "x3, y3 = xe - L3 * np.cos(phie), ye - L3 * np.sin(phie)\n"
               "cos_t2 = (x3**2 + y3**2 - L1**2 - L2**2) / (2 * L1 * L2)\n"
               "t2 = -np.arccos(cos_t2)\n"
               "t1 = np.arctan2(y3, x3) - np.arctan2(L2 * np.sin(t2), L1 + L2 * np.cos(t2))\n"
               "t3 = phie - t1 - t2")
#: q, the target's steps and the wrist point all faked to agree with each other (q = 0: the arm stretched out)
IK_FAKED = "q = np.zeros(3)\nx3, y3 = L1 + L2, 0.0\nt1 = t2 = t3 = 0.0\nframes = fk_frames(arm, q)"
IK_HALF_DONE = IK_SOLUTION.split("cos_t2 =")[0] + "raise NotImplementedError()"
IK_PUBLIC = ('checks.check("steps (t1, t2, t3) - the lab\'s IK [rad]", [t1, t2, t3], q, tol=1e-9)\n'
             "T = fk(arm, q)\n"
             'checks.check("FK(q) - target", [T[0, 3], T[1, 3], np.arctan2(T[1, 0], T[0, 0])], [xe, ye, phie], '
             "tol=1e-9)\nchecks.assert_all()")
IK_HIDDEN = 'checks.check("wrist point (x3, y3) [m]", [x3, y3], frames[2, :2, 3], tol=1e-9)\nchecks.assert_all()'


def write_ik_lab(folder: Path) -> Path:
    """Write the derivation lab (one notebook, 2 public points, 1 hidden point) into ``folder``."""
    import nbformat

    cell = nbformat.v4.new_code_cell
    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    nb.cells = [
        cell('robot = "planar3r_seed004"\nxe, ye, phie = 0.30, 0.20, 0.7854\noutput_dir = "out"', id="params",
             metadata={"tags": ["parameters"]}),
        cell("import numpy as np\nfrom labkit.kinematics import fk, fk_frames, ik\nfrom labkit.reports import Checks\n"
             "from labkit.robot import Robot\narm = Robot.load(robot)\nL1, L2, L3 = (float(a) for a in arm.a)\n"
             "q = ik(arm, [xe, ye, phie], branch='elbow_minus')\nframes = fk_frames(arm, q)\nchecks = Checks('IK steps')",
             id="setup"),
        cell(IK_SOLUTION, id="steps", metadata={"tags": ["solution"]}),
        cell(IK_PUBLIC, id="public", metadata={"tags": ["tests"], "labkit": {"check": "steps and FK", "points": 2}}),
        cell(IK_HIDDEN, id="hidden", metadata={"tags": ["hidden-tests"], "labkit": {"check": "wrist", "points": 1}}),
    ]
    folder.mkdir(parents=True, exist_ok=True)
    nbformat.write(nb, str(folder / IK_NOTEBOOK))
    return folder
