"""Notebooks are the source: committed without outputs, with stable cell ids, through nbstripout.

Covers every notebook under ``notebooks/`` and the lab templates shipped in
``labkit/labs/templates/``. The git round trip below stages a notebook the way a
teaching assistant saves it from JupyterLab after a run (outputs, execution counts,
widget state, timing and language metadata) in a scratch repository with this
repository's ``.gitattributes`` and ``tools/enable-nbstripout.sh``, and checks that git
stores exactly the committed file.
"""

import copy
import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import require

REPO = Path(__file__).resolve().parents[2]
NOTEBOOKS = sorted(p for p in (REPO / "notebooks").rglob("*.ipynb") if ".ipynb_checkpoints" not in p.parts)
TEMPLATES = sorted((REPO / "labkit" / "labs" / "templates").glob("*.ipynb"))
ALL = NOTEBOOKS + TEMPLATES
IDS = [str(p.relative_to(REPO)) for p in ALL]
CELL_ID = re.compile(r"^[a-zA-Z0-9-_]{1,64}$")  # nbformat 4.5


def _volatile_keys():
    """The extra metadata keys the repository's nbstripout filter strips (from the enabling script)."""
    text = (REPO / "tools" / "enable-nbstripout.sh").read_text()
    return re.search(r'^VOLATILE="([^"]*)"', text, re.M).group(1).split()


def test_the_generators_are_gone_and_the_filter_is_declared():
    assert not list((REPO / "tools").glob("make_notebooks*.py")), "notebooks are the source: no generator scripts"
    attributes = (REPO / ".gitattributes").read_text().splitlines()
    assert "*.ipynb filter=nbstripout" in attributes
    assert len(NOTEBOOKS) >= 20 and len(TEMPLATES) == 8


@pytest.mark.parametrize("path", ALL, ids=IDS)
def test_committed_notebook_has_no_outputs_and_stable_ids(path):
    nbformat = require("nbformat")
    strip = require("nbstripout._utils").strip_output
    raw = path.read_text(encoding="utf-8")
    nb = nbformat.reads(raw, as_version=nbformat.NO_CONVERT)
    nbformat.validate(nb)
    assert (nb.nbformat, nb.nbformat_minor) >= (4, 5), "nbformat 4.5 or later (cell ids)"
    ids = [c.get("id") for c in nb.cells]
    assert all(i and CELL_ID.match(i) for i in ids), f"every cell needs an id, got {ids}"
    assert len(set(ids)) == len(ids), "cell ids must be unique"
    for c in nb.cells:
        if c.cell_type == "code":
            assert c.outputs == [] and c.execution_count is None, f"{path.name}: cell {c.id} has outputs"
    assert "widgets" not in nb.metadata, "saved widget state belongs to rendered reports, not the source"
    # the repository's filter (nbstripout --keep-id + the volatile keys) leaves the file byte for byte as it is
    stripped = strip(copy.deepcopy(nb), keep_output=False, keep_count=False, keep_id=True,
                     extra_keys=["metadata.signature", "metadata.widgets", "cell.metadata.collapsed",
                                 "cell.metadata.ExecuteTime", "cell.metadata.execution",
                                 "cell.metadata.heading_collapsed", "cell.metadata.hidden",
                                 "cell.metadata.scrolled", *_volatile_keys()])
    assert stripped == nb, f"{path.name}: nbstripout would change it; run it and commit"
    assert nbformat.writes(nb) + "\n" == raw, f"{path.name}: not in nbformat's layout (indent 1, sorted keys)"


def _as_saved_by_jupyterlab(nb):
    """A copy of ``nb`` as JupyterLab writes it after Run All: outputs, counts, timings, widget state."""
    nb = copy.deepcopy(nb)
    count = 0
    for cell in nb["cells"]:
        if cell["cell_type"] != "code":
            continue
        count += 1
        cell["execution_count"] = count
        cell["metadata"]["execution"] = {"iopub.execute_input": "2026-01-01T10:00:00.000Z",
                                         "shell.execute_reply": "2026-01-01T10:00:01.000Z"}
        cell["metadata"]["scrolled"] = True
        cell["outputs"] = [
            {"name": "stdout", "output_type": "stream", "text": ["PASS  something\n"]},
            {"data": {"image/png": "iVBORw0KGgo=", "text/plain": ["<Figure size 640x480 with 1 Axes>"]},
             "metadata": {}, "output_type": "display_data"},
        ]
    nb["metadata"]["language_info"] = {"codemirror_mode": {"name": "ipython", "version": 3},
                                       "file_extension": ".py", "mimetype": "text/x-python", "name": "python",
                                       "nbconvert_exporter": "python", "pygments_lexer": "ipython3",
                                       "version": "3.11.7"}
    nb["metadata"]["widgets"] = {"application/vnd.jupyter.widget-state+json": {"state": {}, "version_major": 2,
                                                                               "version_minor": 0}}
    return nb


def test_a_notebook_saved_after_a_run_is_committed_unchanged(tmp_path):
    require("nbstripout")
    source = REPO / "notebooks" / "seed002_advanced_robotics" / "01_rotations.ipynb"
    original = source.read_bytes()
    repo = tmp_path / "clone"
    repo.mkdir()

    def git(*args):
        return subprocess.run(["git", *args], cwd=repo, check=True, capture_output=True).stdout

    git("init", "-q")
    (repo / ".gitattributes").write_bytes((REPO / ".gitattributes").read_bytes())
    subprocess.run(["sh", str(REPO / "tools" / "enable-nbstripout.sh")], cwd=repo, check=True, capture_output=True,
                   env={"PATH": "/usr/bin:/bin", "PYTHON": sys.executable, "HOME": str(tmp_path)})
    clean = git("config", "--get", "filter.nbstripout.clean").decode().strip()
    assert "--keep-id" in shlex.split(clean)
    saved = _as_saved_by_jupyterlab(json.loads(original))
    (repo / "lab.ipynb").write_text(json.dumps(saved, indent=1, sort_keys=True, ensure_ascii=False) + "\n",
                                    encoding="utf-8")
    git("add", "lab.ipynb")
    staged = git("show", ":lab.ipynb")
    assert staged == original, "the filter must store the run notebook exactly as committed (no outputs, same ids)"
