"""``labkit lab``: the JupyterLab command line, its kernel spec, and bad input (no server started here;
tests/labs/test_lab_browser.py serves and drives a real JupyterLab)."""

import json
import sys
from pathlib import Path

import pytest

from labkit.exceptions import LabkitError, OptionError

REPO = Path(__file__).resolve().parents[2]


def test_lab_command_serves_the_folder_with_a_labkit_kernel(tmp_path):
    from labkit.labs import lab_command

    argv, env = lab_command(tmp_path, port=8765, no_browser=True, data_dir=tmp_path / "data")
    assert argv[:4] == [sys.executable, "-m", "jupyter", "lab"]
    assert f"--ServerApp.root_dir={tmp_path.resolve()}" in argv and "--ServerApp.port=8765" in argv
    assert "--no-browser" in argv
    assert env["JUPYTER_PATH"].split(":")[0] == str(tmp_path / "data")
    spec = json.loads((tmp_path / "data" / "kernels" / "python3" / "kernel.json").read_text())
    assert spec["argv"][:3] == [sys.executable, "-m", "ipykernel_launcher"]
    assert spec["display_name"] == "Python 3"  # what the notebooks declare: saving one does not change it
    # the kernel imports this checkout's labkit (a source tree, not site-packages)
    assert spec["env"]["PYTHONPATH"].split(":")[0] == str(REPO)
    assert env["PYTHONPATH"].split(":").count(str(REPO)) == 1


def test_lab_command_defaults_to_the_labs_folder_and_opens_a_notebook(tmp_path, monkeypatch):
    from labkit.labs import lab_command
    from labkit.reports import notebooks_root

    argv, _ = lab_command(data_dir=tmp_path)
    assert f"--ServerApp.root_dir={notebooks_root()}" in argv
    nb = REPO / "notebooks" / "seed003_planar3r" / "01_fk_workspace.ipynb"
    argv, _ = lab_command(nb, data_dir=tmp_path)
    assert f"--ServerApp.root_dir={nb.parent}" in argv and argv[-1] == nb.name


def test_lab_command_rejects_bad_input(tmp_path):
    from labkit.labs import lab_command

    with pytest.raises(LabkitError, match="does not exist"):
        lab_command(tmp_path / "nope", data_dir=tmp_path)
    with pytest.raises(OptionError, match="1..65535"):
        lab_command(tmp_path, port=70000, data_dir=tmp_path)


def test_cli_lab_reports_a_missing_folder(tmp_path, capsys):
    from labkit.cli import main

    assert main(["lab", "--no-browser", str(tmp_path / "missing")]) == 2
    assert "does not exist" in capsys.readouterr().err
