"""Every lab notebook under notebooks/ follows the lab conventions and executes headless against the simulated arm.

The execution test is parametrised by glob, so a notebook added to any lab folder is
picked up automatically. Each runs in a fresh kernel (papermill/nbclient) with its
default parameters (``port = "sim://"``: no hardware) and must finish without an error,
which includes its closing reproduced-vs-published assertions.
"""

import ast
from pathlib import Path

import pytest

from conftest import require

ROOT = Path(__file__).resolve().parents[2] / "notebooks"
NOTEBOOKS = sorted(p for p in ROOT.glob("*/*.ipynb") if not p.name.startswith("_"))
IDS = [f"{p.parent.name}/{p.stem}" for p in NOTEBOOKS]


def _read(path):
    nbformat = require("nbformat")
    return nbformat.read(str(path), as_version=4)


def test_there_are_notebooks():
    assert len(NOTEBOOKS) >= 2, f"expected lab notebooks under {ROOT}"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=IDS)
def test_notebook_is_clean_and_documented(path):
    nb = _read(path)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert code, "a notebook without code"
    for c in code:
        assert c.outputs == [] and c.execution_count is None, f"{path.name}: commit notebooks without outputs"
    for c in nb.cells:
        if c.cell_type == "markdown":  # "\theta" written in a non-raw Python string becomes TAB + "heta"
            assert not set(c.source) & set("\t\b\f\v\a"), f"{path.name}: control character in markdown (escape)"
    first = nb.cells[0]
    assert first.cell_type == "markdown" and "seed" in first.source.lower(), \
        "the first cell must say which seed report (file and section) this reproduces"
    tagged = [c for c in nb.cells if "parameters" in c.metadata.get("tags", [])]
    assert len(tagged) == 1, "exactly one cell tagged 'parameters' (papermill)"
    tree = ast.parse(tagged[0].source)
    names = {}
    for node in tree.body:
        assert isinstance(node, ast.Assign), "the parameters cell holds plain assignments only"
        names[node.targets[0].id] = ast.literal_eval(node.value)
    assert "output_dir" in names, "declare output_dir (where the notebook writes files)"
    if "port" in names:
        assert str(names["port"]).startswith("sim://"), "the default port must be the simulated arm"
    if "robot" in names:
        from labkit.robot import bundled_robots

        assert names["robot"] in bundled_robots(), f"robot default {names['robot']!r} is not a bundled robot"
    last_code = code[-1].source
    assert "assert_all()" in last_code or "check(" in last_code, \
        "the notebook must end with its reproduced-vs-published assertions"


@pytest.mark.notebooks
@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=IDS)
def test_notebook_executes(path, tmp_path):
    require("papermill")
    from labkit.reports import execute_notebook, notebook_parameters

    params = {"output_dir": str(tmp_path / "files")} if "output_dir" in notebook_parameters(path) else {}
    result = execute_notebook(path, tmp_path / path.name, params, timeout=300)
    assert result.ok, f"{path.parent.name}/{path.name} failed: {result.error}"
    nb = _read(tmp_path / path.name)
    assert all(c.execution_count is not None for c in nb.cells if c.cell_type == "code")
    # the size budget on the real figures and animations (issue 22): small frames, every image once
    from reports.test_sizes import assert_images_within_budget

    assert_images_within_budget(nb, tmp_path / "report", path.stem)
