"""JupyterLab on the labs: ``labkit lab``.

:func:`lab_command` builds the ``jupyter lab`` command line and environment that
serve a folder of labs (default: :func:`labkit.reports.notebooks_root`) with a
kernel that imports *this* labkit: a kernel spec named ``python3`` (the name the
lab notebooks ask for) is written to a private data folder that is put first on
``JUPYTER_PATH``; it starts the interpreter running labkit, with labkit's source
folder on ``PYTHONPATH`` when labkit is not installed into site-packages (an
editable install or a git worktree). :func:`serve_lab` runs it in the foreground.

**Students' JupyterLab by default**: nbgrader's server extensions and its JupyterLab
extension (the Nbgrader menu, Validate, Create Assignment, Formgrader) are switched off
through a private Jupyter config folder put first on ``JUPYTER_CONFIG_PATH``;
``instructor=True`` (``labkit lab --instructor``) keeps them. **Live figures**: a kernel
started on a notebook that needs them (it connects matplotlib events, ``mpl_connect``, or
asks for ``%matplotlib widget``) gets the ipympl widget backend without a line of set-up.
**Stopping** ``labkit lab`` (SIGTERM, SIGINT or Ctrl-C) stops JupyterLab, which shuts its
kernels down; whatever of it is still running after that is killed.

Example
-------
>>> import tempfile
>>> from labkit.labs import lab_command
>>> folder = tempfile.mkdtemp()
>>> argv, env = lab_command(folder, port=8899, no_browser=True, data_dir=tempfile.mkdtemp())
>>> argv[1:4], "--no-browser" in argv, "--ServerApp.port=8899" in argv
(['-m', 'jupyter', 'lab'], True, True)
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from labkit.exceptions import LabkitError, OptionError, needs_extra
from labkit.reports import notebooks_root

__all__ = ["KERNEL_NAME", "NBGRADER_SERVER_EXTENSIONS", "lab_command", "write_kernel_spec", "serve_lab",
           "live_figures"]

#: the kernel name lab notebooks declare (``metadata.kernelspec.name``)
KERNEL_NAME = "python3"
#: its display name; the same as the notebooks' so that saving a notebook does not change it
KERNEL_DISPLAY_NAME = "Python 3"
#: nbgrader's server extensions (off in a students' JupyterLab)
NBGRADER_SERVER_EXTENSIONS = ("nbgrader.server_extensions.formgrader", "nbgrader.server_extensions.validate_assignment",
                              "nbgrader.server_extensions.assignment_list", "nbgrader.server_extensions.course_list")
#: nbgrader's JupyterLab extension (off in a students' JupyterLab)
NBGRADER_LAB_EXTENSION = "@jupyter/nbgrader"
#: what in a notebook's text asks for live (ipympl) figures
_LIVE_MARKERS = ("mpl_connect", "%matplotlib widget", "%matplotlib ipympl", "button_press_event")


def live_figures(notebook=None) -> bool:
    """In a kernel: switch matplotlib to the ipympl widget backend if the notebook asks for live figures.

    Run by the kernels of ``labkit lab`` at start-up. The notebook is the one Jupyter
    names in ``JPY_SESSION_NAME``; it needs live figures when its text holds
    ``mpl_connect``, ``button_press_event`` or ``%matplotlib widget``.

    Parameters
    ----------
    notebook : str or os.PathLike, optional
        The notebook (default: ``$JPY_SESSION_NAME``).

    Returns
    -------
    bool
        True if the widget backend was switched on.
    """
    path = notebook or os.environ.get("JPY_SESSION_NAME")
    if not path:
        return False
    path = Path(path)
    if not path.is_file():  # a path relative to the server's root: the kernel runs in the notebook's folder
        path = Path.cwd() / path.name
    try:
        text = path.read_text(encoding="utf-8")
    except OSError:
        return False
    if not any(m in text for m in _LIVE_MARKERS):
        return False
    try:
        import ipympl  # noqa: F401
        from IPython import get_ipython

        shell = get_ipython()
        if shell is None:
            return False
        shell.run_line_magic("matplotlib", "widget")
        return True
    except Exception:  # no ipympl, no matplotlib: static figures, as before
        return False


def _write_student_config(config_dir: Path) -> None:
    """nbgrader's server and lab extensions off, in a Jupyter config folder."""
    (config_dir / "labconfig").mkdir(parents=True, exist_ok=True)
    server = {"ServerApp": {"jpserver_extensions": {name: False for name in NBGRADER_SERVER_EXTENSIONS}}}
    (config_dir / "jupyter_server_config.json").write_text(json.dumps(server, indent=1), encoding="utf-8")
    page = {"disabledExtensions": {NBGRADER_LAB_EXTENSION: True}}
    (config_dir / "labconfig" / "page_config.json").write_text(json.dumps(page, indent=1), encoding="utf-8")


def _prepend(path, value):
    """``path`` first on the search-path string ``value``, without duplicates."""
    parts = [p for p in (value or "").split(os.pathsep) if p and p != str(path)]
    return os.pathsep.join([str(path)] + parts)


def _labkit_source_dir() -> Path | None:
    """The folder holding the ``labkit`` package when it is not in site-packages, else None."""
    root = Path(__file__).resolve().parents[2]
    return None if root.name in ("site-packages", "dist-packages") else root


def write_kernel_spec(data_dir) -> Path:
    """Write the ``python3`` kernel spec of this interpreter (with labkit importable) into ``data_dir``.

    Parameters
    ----------
    data_dir : str or os.PathLike
        A Jupyter data folder; the spec goes to ``<data_dir>/kernels/python3/kernel.json``.

    Returns
    -------
    pathlib.Path
        The kernel spec folder.
    """
    spec_dir = Path(data_dir) / "kernels" / KERNEL_NAME
    spec_dir.mkdir(parents=True, exist_ok=True)
    start = "__import__('labkit.labs', fromlist=['live_figures']).live_figures()"
    spec = {"argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}",
                     f"--IPKernelApp.exec_lines={json.dumps([start])}"],
            "display_name": KERNEL_DISPLAY_NAME, "language": "python", "metadata": {"debugger": True}}
    source = _labkit_source_dir()
    if source is not None:
        spec["env"] = {"PYTHONPATH": _prepend(source, os.environ.get("PYTHONPATH"))}
    (spec_dir / "kernel.json").write_text(json.dumps(spec, indent=1), encoding="utf-8")
    return spec_dir


def lab_command(path=None, *, port=None, no_browser=False, data_dir=None, extra_args=(), instructor=False):
    """The ``jupyter lab`` command line and environment serving ``path``.

    Parameters
    ----------
    path : str or os.PathLike, optional
        Folder (or one notebook) to open; default the labs folder
        (:func:`labkit.reports.notebooks_root`).
    port : int, optional
        TCP port (default: JupyterLab's, 8888 or the next free one).
    no_browser : bool
        Do not open a browser (print the URL with its token instead).
    data_dir : str or os.PathLike, optional
        Where the kernel spec is written (default: a new temporary folder).
    extra_args : sequence of str
        Further ``jupyter lab`` options.
    instructor : bool
        Keep nbgrader's extensions (default: a students' JupyterLab without them).

    Returns
    -------
    argv : list of str
        The command line (this interpreter, ``-m jupyter lab ...``).
    env : dict of str to str
        The environment: this process's, with ``JUPYTER_PATH`` starting at ``data_dir``,
        labkit's source folder on ``PYTHONPATH`` when needed, and (students' mode)
        ``JUPYTER_CONFIG_PATH`` starting at ``data_dir/config``.

    Raises
    ------
    LabkitError
        ``path`` does not exist.
    OptionError
        ``port`` is not in 1..65535.
    """
    target = Path(path).expanduser() if path is not None else notebooks_root()
    if not target.exists():
        raise LabkitError(f"expected a folder or notebook to open, got {str(target)!r} (it does not exist)")
    target = target.resolve()
    root, start = (target.parent, target.name) if target.is_file() else (target, None)
    if port is not None and not 1 <= int(port) <= 65535:
        raise OptionError(f"expected a port in 1..65535, got {port}")
    data_dir = Path(data_dir) if data_dir is not None else Path(tempfile.mkdtemp(prefix="labkit-lab-"))
    write_kernel_spec(data_dir)
    env = dict(os.environ)
    env["JUPYTER_PATH"] = _prepend(data_dir, env.get("JUPYTER_PATH"))
    if not instructor:
        _write_student_config(data_dir / "config")
        env["JUPYTER_CONFIG_PATH"] = _prepend(data_dir / "config", env.get("JUPYTER_CONFIG_PATH"))
    source = _labkit_source_dir()
    if source is not None:
        env["PYTHONPATH"] = _prepend(source, env.get("PYTHONPATH"))
    argv = [sys.executable, "-m", "jupyter", "lab", f"--ServerApp.root_dir={root}",
            f"--MultiKernelManager.default_kernel_name={KERNEL_NAME}"]
    if port is not None:
        argv.append(f"--ServerApp.port={int(port)}")
    if no_browser:
        argv.append("--no-browser")
    if hasattr(os, "geteuid") and os.geteuid() == 0:  # containers and CI run as root; Jupyter refuses without it
        argv.append("--allow-root")
    argv += list(extra_args)
    if start:
        argv.append(start)
    return argv, env


def _descendants(pid) -> list:
    """The pids of all descendants of ``pid`` (psutil), [] once it is gone."""
    with needs_extra("lab"):
        import psutil

    try:
        return [child.pid for child in psutil.Process(pid).children(recursive=True)]
    except psutil.Error:
        return []


def serve_lab(path=None, *, port=None, no_browser=False, extra_args=(), instructor=False) -> int:
    """Run JupyterLab on ``path`` in the foreground until it is stopped (Ctrl+C or SIGTERM).

    Parameters
    ----------
    path : str or os.PathLike, optional
        Folder or notebook (default the labs folder).
    port : int, optional
        TCP port.
    no_browser : bool
        Do not open a browser.
    extra_args : sequence of str
        Further ``jupyter lab`` options.
    instructor : bool
        Keep nbgrader's extensions (default off: a students' JupyterLab).

    Returns
    -------
    int
        JupyterLab's exit status (0 after a normal shutdown or Ctrl+C).

    Raises
    ------
    LabkitError
        ``path`` does not exist.
    MissingExtraError
        JupyterLab is not installed (``pip install 'labkit[lab]'``).
    """
    import signal
    import threading

    with needs_extra("lab"):
        import jupyterlab  # noqa: F401
    with tempfile.TemporaryDirectory(prefix="labkit-lab-") as data_dir:
        argv, env = lab_command(path, port=port, no_browser=no_browser, data_dir=data_dir, extra_args=extra_args,
                                instructor=instructor)
        proc = subprocess.Popen(argv, env=env)
        seen = set()
        done = threading.Event()

        def watch():  # the processes JupyterLab starts (kernels run in sessions of their own)
            while not done.wait(0.5):
                seen.update(_descendants(proc.pid))

        threading.Thread(target=watch, daemon=True).start()
        previous = signal.signal(signal.SIGTERM, lambda *_: proc.send_signal(signal.SIGTERM)) \
            if threading.current_thread() is threading.main_thread() else None
        try:
            try:
                return proc.wait()
            except KeyboardInterrupt:  # JupyterLab got the SIGINT too and shuts down
                proc.send_signal(signal.SIGTERM)
                try:
                    proc.wait(timeout=20)
                    return 0
                except subprocess.TimeoutExpired:
                    proc.kill()
                    return proc.wait()
        finally:
            done.set()
            if proc.poll() is None:
                proc.terminate()
                try:
                    proc.wait(timeout=20)
                except subprocess.TimeoutExpired:
                    proc.kill()
            seen.update(_descendants(proc.pid))
            for pid in seen:  # a kernel JupyterLab did not stop
                try:
                    os.kill(pid, signal.SIGKILL)
                except OSError:
                    pass
            if previous is not None:
                signal.signal(signal.SIGTERM, previous)
