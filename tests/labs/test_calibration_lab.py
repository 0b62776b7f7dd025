"""The calibration notebook of ``labkit new`` (``05_calibration``) on an arm whose last joint does not move the tool
point (the Cobra 600 SCARA: the tool on the wrist axis): the fit leaves that joint's offset out, so every fitted offset
has a finite confidence interval and no 'not identifiable' warning reaches the report.

Only that notebook is rendered (the others are covered by tests/labs/test_new_lab.py).
"""

import json
import math

import pytest

from conftest import require


@pytest.mark.slow
@pytest.mark.notebooks
def test_calibration_fits_only_the_offsets_of_joints_that_move_the_tool_point(tmp_path, capsys):
    require("papermill")
    nbformat = require("nbformat")
    from labkit.cli import main

    lab = tmp_path / "scara"
    assert main(["new", str(lab), "--robot", "cobra600_scara"]) == 0
    for nb in lab.glob("*.ipynb"):
        if nb.stem != "05_calibration":
            nb.unlink()
    capsys.readouterr()
    reports = tmp_path / "reports"
    assert main(["render", str(lab), "--no-pdf", "-j", "1", "-o", str(reports)]) == 0, capsys.readouterr()
    nb = nbformat.read(str(reports / "scara" / "05_calibration.ipynb"), as_version=4)
    text = json.dumps([c.get("outputs", []) for c in nb.cells])
    assert "left out (they do not move the tool point): wrist" in text
    assert "not identifiable" not in text and "UserWarning" not in text
    fit_cell = next(c for c in nb.cells if "#| label: tbl-fit" in c.source)
    table = next(o["data"]["text/plain"] for o in fit_cell.outputs if "text/plain" in o.get("data", {}))
    rows = [line.split() for line in table.splitlines()[1:]]
    assert [r[0] for r in rows] == ["offset[1]", "offset[2]", "offset[3]"]
    assert all(math.isfinite(float(r[5])) for r in rows)  # std_error: finite for every fitted offset
