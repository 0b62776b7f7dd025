"""``labkit lab`` in a real browser: JupyterLab served on 127.0.0.1, driven by Debian's headless Chromium.

The test starts ``python -m labkit lab --no-browser --port P LABS`` (random free port, a token,
its own runtime/config/data/settings folders under the pytest tmp dir), opens two seed
notebooks in Chromium through Playwright (``executable_path=/usr/bin/chromium``; Playwright's
own browser downloads are never used), and

* runs all cells of ``seed003_planar3r/05_via_points_on_arm`` (the arm is ``sim://``), waits for
  the kernel to go idle, and checks that the final ``Checks`` cell reports pass rows and no
  failure, that no cell raised, and that a figure is shown;
* runs ``seed002_advanced_robotics/03_rpp_jacobian_forces``, moves the theta1 slider of its
  widget with the keyboard and checks that the printed joint forces change.

Screenshots are written to the test's tmp dir (``lab_run_all.png``, ``lab_widget_*.png``).
"""

import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest

from conftest import require

REPO = Path(__file__).resolve().parents[2]
CHROMIUM = "/usr/bin/chromium"
TOKEN = "labkit-browser-test"
RUN_ALL = "seed003_planar3r/05_via_points_on_arm.ipynb"
WIDGETS = "seed002_advanced_robotics/03_rpp_jacobian_forces.ipynb"

pytestmark = [pytest.mark.slow, pytest.mark.notebooks, pytest.mark.xdist_group("jupyterlab")]


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def lab_server(tmp_path):
    """``labkit lab`` serving a copy of two seed labs; yields (base URL, labs folder)."""
    require("jupyterlab")
    labs = tmp_path / "labs"
    for rel in (RUN_ALL, WIDGETS):
        (labs / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(REPO / "notebooks" / rel, labs / rel)
    settings = tmp_path / "lab-settings" / "@jupyterlab" / "notebook-extension"
    settings.mkdir(parents=True)
    # render every cell (no virtual scrolling), so the page holds every output the test reads
    (settings / "tracker.jupyterlab-settings").write_text(json.dumps({"windowingMode": "none"}))
    apputils = tmp_path / "lab-settings" / "@jupyterlab" / "apputils-extension"
    apputils.mkdir(parents=True)
    (apputils / "notification.jupyterlab-settings").write_text(json.dumps({"fetchNews": "false",
                                                                           "checkForUpdates": False}))
    (tmp_path / "home").mkdir()
    port = _free_port()
    env = dict(os.environ, JUPYTER_TOKEN=TOKEN, HOME=str(tmp_path / "home"),
               JUPYTER_RUNTIME_DIR=str(tmp_path / "runtime"), JUPYTER_CONFIG_DIR=str(tmp_path / "config"),
               JUPYTER_DATA_DIR=str(tmp_path / "data"), JUPYTERLAB_SETTINGS_DIR=str(tmp_path / "lab-settings"),
               JUPYTERLAB_WORKSPACES_DIR=str(tmp_path / "workspaces"),
               PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep))
    log = open(tmp_path / "jupyterlab.log", "wb")
    proc = subprocess.Popen([sys.executable, "-m", "labkit", "lab", "--no-browser", "--port", str(port), str(labs)],
                            cwd=tmp_path, env=env, stdout=log, stderr=subprocess.STDOUT)
    base = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 120
        while True:
            try:
                urllib.request.urlopen(f"{base}/api/status?token={TOKEN}", timeout=2).read()
                break
            except OSError:
                if proc.poll() is not None or time.monotonic() > deadline:
                    log.flush()
                    pytest.fail("labkit lab did not serve: " + (tmp_path / "jupyterlab.log").read_text()[-3000:])
                time.sleep(0.3)
        specs = json.loads(urllib.request.urlopen(f"{base}/api/kernelspecs?token={TOKEN}").read())
        kernel = specs["kernelspecs"]["python3"]["spec"]
        assert kernel["argv"][0] == sys.executable, "the kernel must be the interpreter that has labkit"
        yield base, labs
    finally:
        # SIGTERM to `labkit lab` reaches JupyterLab, which shuts its kernels down
        for p in _children(proc.pid) + [proc.pid]:
            try:
                os.kill(p, signal.SIGTERM)
            except ProcessLookupError:
                pass
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        log.close()


def _children(pid):
    """Direct child pids of ``pid`` (Linux /proc)."""
    out = []
    for status in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = status.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            out.append(int(status.parent.name))
    return out


@pytest.fixture
def browser():
    sync_api = require("playwright.sync_api")
    assert Path(CHROMIUM).exists(), "Debian's chromium is needed (tools/install-system-deps.sh test)"
    with sync_api.sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=CHROMIUM, headless=True,
                               args=["--no-sandbox", "--disable-background-networking", "--disable-component-update",
                                     "--disable-gpu"])
        try:
            yield b
        finally:
            b.close()


def _open_and_run_all(page, base, rel):
    page.goto(f"{base}/lab/tree/{rel}?token={TOKEN}")
    page.wait_for_selector(".jp-Notebook .jp-Cell", timeout=120_000)
    # the kernel has started and connected: the status bar says "Python 3 | Idle"
    page.wait_for_function("() => /Python 3 \\| Idle/.test(document.querySelector('#jp-main-statusbar')?.innerText)",
                           timeout=120_000, polling=250)
    page.click('.lm-MenuBar-itemLabel:text-is("Run")')
    page.click('.lm-Menu-itemLabel:text-is("Run All Cells")')
    # every code cell has an execution count ([n]: not [*]: or [ ]:) and the kernel is idle again
    page.wait_for_function(
        """() => {
            const prompts = [...document.querySelectorAll('.jp-CodeCell .jp-InputArea-prompt')];
            const busy = document.querySelector('.jp-Notebook-ExecutionIndicator[data-status="busy"]');
            return prompts.length > 0 && !busy && prompts.every(p => /\\[\\d+\\]/.test(p.textContent));
        }""",
        timeout=300_000, polling=500)
    page.wait_for_selector('.jp-Notebook-ExecutionIndicator[data-status="idle"]', timeout=60_000)


def test_run_all_cells_of_a_seed_lab_in_jupyterlab(lab_server, browser, tmp_path):
    base, _ = lab_server
    page = browser.new_page(viewport={"width": 1400, "height": 1000})
    _open_and_run_all(page, base, RUN_ALL)
    outputs = page.locator(".jp-CodeCell .jp-OutputArea")
    texts = page.locator(".jp-CodeCell").evaluate_all("cells => cells.map(c => c.innerText)")
    errors = page.locator('.jp-OutputArea-output[data-mime-type="application/vnd.jupyter.stderr"]')
    error_text = "\n".join(errors.all_inner_texts())
    assert "Traceback" not in error_text and "Error" not in error_text.split("\n")[0], error_text[:2000]
    last = texts[-1]
    results = re.findall(r"^.*\t(pass|FAIL)\t.*$", last, flags=re.M)  # the checks table's result column
    assert results and set(results) == {"pass"}, f"the final checks cell must pass, it shows:\n{last[:2000]}"
    figures = page.locator(".jp-OutputArea-output img")
    assert figures.count() >= 1, "a figure must be shown"
    width = figures.first.evaluate("img => img.naturalWidth")
    assert width > 100, f"the figure must have loaded, naturalWidth {width}"
    assert outputs.count() >= 3
    figures.first.scroll_into_view_if_needed()
    page.screenshot(path=str(tmp_path / "lab_run_all_figure.png"))
    page.locator(".jp-CodeCell").last.scroll_into_view_if_needed()
    page.screenshot(path=str(tmp_path / "lab_run_all.png"))
    print(f"screenshots: {tmp_path / 'lab_run_all.png'}, {tmp_path / 'lab_run_all_figure.png'}")


def test_a_widget_slider_changes_the_output(lab_server, browser, tmp_path):
    base, _ = lab_server
    page = browser.new_page(viewport={"width": 1400, "height": 1000})
    _open_and_run_all(page, base, WIDGETS)
    widget = page.locator(".jupyter-widgets.widget-interact, .widget-interact").first
    widget.wait_for(timeout=60_000)
    widget.scroll_into_view_if_needed()
    output = widget.locator(".widget-output").last  # the interact's Output widget (its children are replaced)
    text_js = "document.querySelector('.widget-interact .widget-output')?.innerText.trim() ?? ''"

    def forces():
        return output.inner_text().strip()

    page.wait_for_function(f"() => ({text_js}).includes('tau1')", timeout=60_000)
    before = forces()
    page.screenshot(path=str(tmp_path / "lab_widget_before.png"))
    # independent of the page: tau = J^T F of the seed's RPP arm at theta1 = 30 deg, d2 = d3 = 1 m
    import numpy as np
    from labkit.kinematics import jacobian, joint_torques
    from labkit.robot import Robot

    tau = joint_torques(jacobian(Robot.load("rpp_seed002"), [np.radians(30.0), 1.0, 1.0]), [1, 2, 3, 0, 0, 0])
    expected = f"tau1 = {tau[0]:.4f} N m   f_d2 = {tau[1]:.4f} N   f_d3 = {tau[2]:.4f} N"
    assert before != expected
    handle = widget.locator(".noUi-handle, .ui-slider-handle").first
    handle.focus()
    for _ in range(30):  # theta1 += 30 deg, one step (1 deg) per key press
        page.keyboard.press("ArrowRight")
    # the kernel answers every intermediate value; wait for the one of the final slider position
    page.wait_for_function(f"text => ({text_js}) === text", arg=expected, timeout=60_000)
    after = forces()
    page.screenshot(path=str(tmp_path / "lab_widget_after.png"))
    readout = widget.locator(".widget-readout").first.inner_text().strip()
    assert float(readout) == pytest.approx(30.0), f"theta1 slider readout {readout!r}"
    assert before.startswith("tau1 = ") and after == expected, "moving the slider must change the printed joint forces"
    print(f"before: {before}\nafter:  {after}\nscreenshots in {tmp_path}")
