"""The dynamics notebook of ``labkit new`` (``07_dynamics``): rendered and reported on the virtual arm for the
seed arm (hobby servos, assumed inertias), the PUMA 560 (geared, Armstrong/Corke inertias, no servo stall torques)
and the OpenMANIPULATOR-X (a Dynamixel bus, its URDF's inertias, the present current read as torque).

Only the dynamics notebook of each lab is rendered (the others are covered by tests/labs/test_new_lab.py and
tests/labs/test_bus_lab.py), through the command line as a user runs it: ``labkit new``, ``labkit render``,
``labkit report``.
"""

import json

import pytest

from conftest import require

ARMS = ("arduino_arm_3dof", "puma560", "openmanipulator_x")


@pytest.mark.slow
@pytest.mark.notebooks
def test_the_dynamics_notebook_renders_and_reports_for_three_arms(tmp_path, capsys):
    require("papermill")
    nbformat = require("nbformat")
    from labkit.cli import main

    labs = tmp_path / "labs"
    for robot in ARMS:
        assert main(["new", str(labs / robot), "--robot", robot]) == 0
        for nb in (labs / robot).glob("*.ipynb"):
            if nb.stem != "07_dynamics":  # a lab of its dynamics notebook only
                nb.unlink()
    capsys.readouterr()
    reports = tmp_path / "reports"
    assert main(["render", *(str(labs / r) for r in ARMS), "--no-pdf", "-j", "2", "-o", str(reports)]) == 0, \
        capsys.readouterr()
    for robot in ARMS:
        assert main(["report", str(labs / robot), "--executed", str(reports / robot), "--to", "html",
                     "-o", str(tmp_path / "book" / robot)]) == 0, capsys.readouterr()
        html = (tmp_path / "book" / f"{robot}.html").read_text(encoding="utf-8")
        assert "Free swing" in html or "free swing" in html
        nb = nbformat.read(str(reports / robot / "07_dynamics.ipynb"), as_version=4)
        text = json.dumps([c.get("outputs", []) for c in nb.cells])
        assert "pass" in text and "FAIL" not in text
        # the load on the arm: current x torque constant on the bus, the fitted compliance of hobby servos
        load = "measured - predicted gravity torque" if robot == "openmanipulator_x" else "RMS residual of the fit"
        assert load in text, robot
    # the PUMA's file names no servo stall torques: the notebook says so instead of a budget
    puma = json.dumps([c.get("outputs", []) for c in nbformat.read(str(reports / "puma560" / "07_dynamics.ipynb"),
                                                                   as_version=4).cells])
    assert "no budget for the plan" in puma
