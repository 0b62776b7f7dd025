"""``labkit lab``: the JupyterLab command line, its kernel spec, and bad input (no server started here;
tests/labs/test_lab_browser.py serves and drives a real JupyterLab)."""

import json
import os
import sys
from pathlib import Path

import pytest

from conftest import require
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


def test_students_lab_switches_nbgrader_off_instructors_keeps_it(tmp_path):
    from labkit.labs import lab_command
    from labkit.labs._serve import NBGRADER_LAB_EXTENSION, NBGRADER_SERVER_EXTENSIONS

    _, env = lab_command(tmp_path, data_dir=tmp_path / "student")
    config = tmp_path / "student" / "config"
    assert env["JUPYTER_CONFIG_PATH"].split(os.pathsep)[0] == str(config)
    server = json.loads((config / "jupyter_server_config.json").read_text())["ServerApp"]["jpserver_extensions"]
    assert server == {name: False for name in NBGRADER_SERVER_EXTENSIONS}
    page = json.loads((config / "labconfig" / "page_config.json").read_text())
    assert page["disabledExtensions"] == {NBGRADER_LAB_EXTENSION: True}
    _, env = lab_command(tmp_path, data_dir=tmp_path / "instructor", instructor=True)
    assert not (tmp_path / "instructor" / "config").exists()
    assert str(tmp_path / "instructor" / "config") not in env.get("JUPYTER_CONFIG_PATH", "")


def test_live_figures_only_for_notebooks_that_ask(tmp_path):
    from labkit.labs import live_figures

    static = tmp_path / "static.ipynb"
    static.write_text(json.dumps({"cells": [{"source": "plt.plot([1, 2])"}]}))
    assert live_figures(static) is False
    assert live_figures(tmp_path / "missing.ipynb") is False
    live = tmp_path / "live.ipynb"
    live.write_text(json.dumps({"cells": [{"source": "fig.canvas.mpl_connect('button_press_event', on_click)"}]}))
    assert live_figures(live) is False  # it asks, but outside a kernel there is no shell to switch


def _free_port():
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _descendants(pid):
    from labkit.labs._serve import _descendants as tree

    return tree(pid)


@pytest.mark.slow
def test_stopping_labkit_lab_stops_jupyterlab_and_its_kernels(tmp_path):
    """SIGTERM to `labkit lab` (what `kill PID` sends): JupyterLab and the kernel it started are gone, the port is
    free, and nbgrader's Formgrader is not served (students' mode)."""
    import signal
    import subprocess
    import time
    import urllib.error
    import urllib.request

    require("jupyterlab")
    port, token = _free_port(), "labkit-stop-test"
    env = dict(os.environ, JUPYTER_TOKEN=token, HOME=str(tmp_path), JUPYTER_RUNTIME_DIR=str(tmp_path / "rt"),
               PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep))
    log = open(tmp_path / "lab.log", "wb")
    proc = subprocess.Popen([sys.executable, "-m", "labkit", "lab", "--no-browser", "--port", str(port), str(tmp_path)],
                            env=env, stdout=log, stderr=subprocess.STDOUT)
    base = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 120
        while True:
            try:
                urllib.request.urlopen(f"{base}/api/status?token={token}", timeout=2).read()
                break
            except OSError:
                assert proc.poll() is None and time.monotonic() < deadline, (tmp_path / "lab.log").read_text()[-2000:]
                time.sleep(0.3)
        req = urllib.request.Request(f"{base}/api/kernels?token={token}", data=b"{}", method="POST")
        kernel = json.loads(urllib.request.urlopen(req, timeout=60).read())
        assert kernel["id"]
        with pytest.raises(urllib.error.HTTPError) as err:
            urllib.request.urlopen(f"{base}/formgrader?token={token}", timeout=10)
        assert err.value.code == 404
        deadline = time.monotonic() + 30
        while not any("ipykernel" in _cmdline(p) for p in _descendants(proc.pid)):
            assert time.monotonic() < deadline, "no kernel process"
            time.sleep(0.2)
        family = _descendants(proc.pid)
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=60) is not None
        time.sleep(0.5)
        alive = [p for p in family if _cmdline(p)]
        assert not alive, [(p, _cmdline(p)) for p in alive]
        with pytest.raises(OSError):
            urllib.request.urlopen(f"{base}/api/status?token={token}", timeout=2)
    finally:
        if proc.poll() is None:
            proc.kill()
        log.close()
    assert "nbgrader_config.py" not in (tmp_path / "lab.log").read_text()


def _cmdline(pid):
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except OSError:
        return ""


@pytest.mark.slow
def test_a_labkit_lab_kernel_gets_live_figures_where_the_notebook_asks(tmp_path, monkeypatch):
    """The kernel spec of `labkit lab` switches to ipympl for a notebook with mpl_connect, not for another."""
    require("ipympl")
    manager = require("jupyter_client.manager")
    from labkit.labs._serve import write_kernel_spec

    write_kernel_spec(tmp_path / "data")
    monkeypatch.setenv("JUPYTER_PATH", str(tmp_path / "data"))
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]))
    backends = {}
    for name, source in (("click", "fig.canvas.mpl_connect('button_press_event', on_click)"), ("static", "plt.plot()")):
        nb = tmp_path / f"{name}.ipynb"
        nb.write_text(json.dumps({"cells": [{"cell_type": "code", "source": source}]}))
        monkeypatch.setenv("JPY_SESSION_NAME", str(nb))
        km, kc = manager.start_new_kernel(kernel_name="python3")
        try:
            out = []
            kc.execute_interactive(  # the canvas's module: the backend's name reads "widget" with some installs
                "import matplotlib.pyplot as plt; print(type(plt.figure().canvas).__module__)", timeout=60,
                output_hook=lambda m: out.append(m["content"].get("text", "")) if m["msg_type"] == "stream" else None)
            backends[name] = "".join(out).strip()
        finally:
            kc.stop_channels()
            km.shutdown_kernel(now=True)
    assert "ipympl" in backends["click"], backends
    assert "ipympl" not in backends["static"], backends
