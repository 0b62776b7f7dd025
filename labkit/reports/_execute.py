"""Finding, parameterising and executing the lab notebooks.

A lab notebook lives in ``notebooks/<lab>/<name>.ipynb`` and has one cell tagged
``parameters`` (papermill's convention) whose defaults run without hardware
(``port = "sim://"``). :func:`execute_notebook` runs a notebook in a fresh
kernel with papermill, injecting parameter overrides after that cell, and never
raises for an error *inside* the notebook: the executed notebook (with the
failing cell and its traceback) is written anyway and the failure is described
by the returned :class:`ExecutionResult`.

Example
-------
>>> from labkit.reports import parse_parameter
>>> parse_parameter("0.5"), parse_parameter("/dev/ttyACM0"), parse_parameter("[1, 2]")
(0.5, '/dev/ttyACM0', [1, 2])
"""

from __future__ import annotations

import ast
import logging
import os
import re
import time
from dataclasses import dataclass, field
from pathlib import Path

from labkit.exceptions import LabkitError, OptionError, needs_extra

__all__ = ["CELL_TIMEOUT", "kernel_manager_class", "chapter_of",
    "ExecutionResult",
    "notebooks_root",
    "find_notebooks",
    "lab_of",
    "parse_parameter",
    "notebook_parameters",
    "execute_notebook",
]

#: environment variable pointing at the notebooks folder (default: ./notebooks, else the source tree's)
ROOT_ENV = "LABKIT_NOTEBOOKS"
#: seconds one cell may run before the execution is abandoned
CELL_TIMEOUT = 600
#: most kernels started for one notebook when a kernel dies before its first reply (seen with several
#: kernels starting at once on a loaded 2-core machine); no cell has run in such a kernel
KERNEL_STARTS = 3


@dataclass(frozen=True)
class ExecutionResult:
    """Outcome of executing one notebook.

    Attributes
    ----------
    source : Path
        The notebook that was executed.
    output : Path
        The executed notebook (written even when a cell failed).
    ok : bool
        True when every cell ran without an error.
    seconds : float
        Wall time of the execution [s].
    error : str
        ``"<notebook>, cell <n>, line <k>: <ExceptionName>: <message>"`` of the first failure
        (``n`` counts the cells of the source notebook from 1), "" when ok.
    cell : int or None
        Index of the failing cell in the executed notebook, None when ok.
    parameters : dict
        The parameter overrides that were injected.
    """

    source: Path
    output: Path
    ok: bool
    seconds: float
    error: str = ""
    cell: int | None = None
    parameters: dict = field(default_factory=dict)


def notebooks_root() -> Path:
    """The folder holding the lab notebooks.

    ``$LABKIT_NOTEBOOKS`` if set, else ``./notebooks`` when it exists, else the
    ``notebooks/`` folder next to the installed (editable) ``labkit`` package.

    Returns
    -------
    pathlib.Path
        The first existing candidate, resolved.

    Raises
    ------
    LabkitError
        If none of these exists.
    """
    candidates = []
    if os.environ.get(ROOT_ENV):
        candidates.append(Path(os.environ[ROOT_ENV]))
    candidates += [Path.cwd() / "notebooks", Path(__file__).resolve().parents[2] / "notebooks"]
    for c in candidates:
        if c.is_dir():
            return c.resolve()
    raise LabkitError("no notebooks folder found; tried " + ", ".join(str(c) for c in candidates))


def _is_notebook(p: Path) -> bool:
    return p.suffix == ".ipynb" and ".ipynb_checkpoints" not in p.parts and not p.name.startswith("_")


def find_notebooks(selection=None, root=None) -> list[Path]:
    """The lab notebooks to execute, sorted by lab then name.

    Parameters
    ----------
    selection : sequence of str or Path, optional
        Notebook files, lab folders, or lab names (folder names under ``root``);
        a substring of a notebook path (e.g. ``"seed002"``) also matches. Default:
        every ``<root>/<lab>/*.ipynb``.
    root : Path, optional
        The notebooks folder (default :func:`notebooks_root`).

    Returns
    -------
    list of Path

    Raises
    ------
    LabkitError
        If an entry of ``selection`` matches nothing (the message lists the labs).
    """
    if selection and all(Path(item).exists() for item in selection):
        root = Path(root) if root is not None else Path.cwd()  # only paths: no labs folder needed
    else:
        root = Path(root) if root is not None else notebooks_root()
    every = sorted(p.resolve() for p in root.glob("*/*.ipynb") if _is_notebook(p))
    if not selection:
        return every
    found: list[Path] = []
    for item in selection:
        p = Path(item)
        if p.is_file():
            hits = [p.resolve()]
        elif p.is_dir():
            hits = sorted(q.resolve() for q in p.glob("*.ipynb") if _is_notebook(q))
        elif (root / str(item)).is_dir():
            hits = sorted(q.resolve() for q in (root / str(item)).glob("*.ipynb") if _is_notebook(q))
        else:
            hits = [q for q in every if str(item) in str(q.relative_to(root))]
        if not hits:
            labs = sorted({q.parent.name for q in every})
            raise LabkitError(f"no notebook matches {str(item)!r}; labs under {root}: {', '.join(labs)}")
        found += [h for h in hits if h not in found]
    return found


def lab_of(notebook) -> str:
    """The lab name of a notebook: its folder name (``notebooks/<lab>/x.ipynb``).

    Parameters
    ----------
    notebook : str or os.PathLike
        Notebook path.

    Returns
    -------
    str
        Name of the folder holding the notebook (after resolving the path).
    """
    return Path(notebook).resolve().parent.name


def parse_parameter(text: str):
    """Parse a ``-p name value`` value: a Python literal if it is one, else the string.

    Examples: ``"3"`` -> 3, ``"0.5"`` -> 0.5, ``"True"`` -> True, ``"None"`` -> None,
    ``"[0, 1]"`` -> [0, 1], ``"sim://"`` -> ``"sim://"``.

    Parameters
    ----------
    text : str
        Value as typed on the command line.

    Returns
    -------
    object
        ``ast.literal_eval(text)``, or ``text`` itself if it is not a literal.
    """
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError, MemoryError, RecursionError):
        return text


def notebook_parameters(notebook) -> dict:
    """The parameters (name -> default source text) declared by a notebook's ``parameters`` cell.

    The cell is parsed with :mod:`ast` (papermill's own line parser rejects values such as
    ``"sim://?clock=lockstep"``); every top-level assignment is a parameter.

    Parameters
    ----------
    notebook : str or os.PathLike
        Notebook file (``.ipynb``).

    Returns
    -------
    dict of str to str
        Parameter name -> source text of its default value, in cell order.

    Raises
    ------
    LabkitError
        If the notebook has no cell tagged ``parameters`` or the cell is not valid Python.
    """
    with needs_extra("reports"):
        import nbformat

    nb = nbformat.read(str(notebook), as_version=4)
    cells = [c for c in nb.cells if "parameters" in c.get("metadata", {}).get("tags", [])]
    if not cells:
        raise LabkitError(f"{notebook} has no cell tagged 'parameters'")
    source = cells[0].source
    try:
        tree = ast.parse(source)
    except SyntaxError as exc:
        raise LabkitError(f"{notebook}: the parameters cell is not valid Python: {exc}") from exc
    params = {}
    for node in tree.body:
        targets = node.targets if isinstance(node, ast.Assign) else [node.target] if isinstance(node, ast.AnnAssign) else []
        for target in targets:
            if isinstance(target, ast.Name) and getattr(node, "value", None) is not None:
                params[target.id] = ast.get_source_segment(source, node.value)
    return params


def check_parameter_types(name, declared, parameters):
    """Refuse overrides whose type does not fit the notebook's default (before anything runs).

    A default that is a Python literal fixes the type: a number needs a finite number (an int
    where the default is an int), a bool a bool, a string a string, a list or tuple a list or
    tuple; ``None`` and defaults that are expressions accept anything.

    Parameters
    ----------
    name : str
        Notebook name for the message.
    declared : dict of str to str
        Parameter name -> source text of its default (:func:`notebook_parameters`).
    parameters : dict
        Overrides (name -> value).

    Raises
    ------
    OptionError
        Naming the parameter, its default and the value received (a ``ValueError``).
    """
    import math

    for key, value in parameters.items():
        try:
            default = ast.literal_eval(declared.get(key, "None"))
        except (ValueError, SyntaxError, MemoryError, RecursionError):
            continue  # an expression: no type to compare with
        if default is None:
            continue
        if isinstance(default, bool):
            ok = isinstance(value, bool)
        elif isinstance(default, int):
            ok = isinstance(value, int) and not isinstance(value, bool)
        elif isinstance(default, float):
            ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
        elif isinstance(default, (list, tuple)):
            ok = isinstance(value, (list, tuple))
        else:
            ok = isinstance(value, type(default))
        if not ok:
            kind = "a finite number" if isinstance(default, float) else f"a {type(default).__name__}"
            raise OptionError(f"{name}: parameter {key} expects {kind} like its default {declared[key]}, "
                              f"got {value!r} ({type(value).__name__}); nothing was run")


_KERNEL_MANAGER = None


def kernel_manager_class():
    """An AsyncKernelManager whose client polls its sockets in short slices.

    Works around a missed wake-up in ``jupyter_client``'s asyncio ``get_msg`` seen with
    ipywidgets (nbclient issue #312, open): a cell's ``execute_reply`` sits in the socket
    while the client waits for the whole cell timeout (600 s) before reading it. Polling in
    0.2 s slices re-checks the socket, so a missed wake-up costs at most 0.2 s.

    Returns
    -------
    type
        A subclass of ``jupyter_client.manager.AsyncKernelManager`` (built once, then cached).
    """
    global _KERNEL_MANAGER
    if _KERNEL_MANAGER is not None:
        return _KERNEL_MANAGER
    from queue import Empty

    with needs_extra("reports"):
        from jupyter_client.asynchronous import AsyncKernelClient
        from jupyter_client.channels import AsyncZMQSocketChannel
        from jupyter_client.manager import AsyncKernelManager
        from traitlets import Type

    class SlicedPollChannel(AsyncZMQSocketChannel):
        async def get_msg(self, timeout=None):
            deadline = None if timeout is None else time.monotonic() + timeout
            while True:
                left = 0.2 if deadline is None else max(0.0, min(0.2, deadline - time.monotonic()))
                if await self.socket.poll(int(left * 1000)):
                    return await self._recv()
                if deadline is not None and time.monotonic() >= deadline:
                    raise Empty

    class SlicedPollClient(AsyncKernelClient):
        shell_channel_class = Type(SlicedPollChannel)
        iopub_channel_class = Type(SlicedPollChannel)

    class SlicedPollKernelManager(AsyncKernelManager):
        client_factory = Type(SlicedPollClient, klass=AsyncKernelClient)

        async def _async_interrupt_kernel(self):
            # jupyter_client interrupts (SIGINT) a kernel before asking it to shut down; an idle
            # kernel then logs "KeyboardInterrupt caught in kernel". A finished notebook has
            # nothing to interrupt: only a timed-out cell (not shutting down) is interrupted.
            if self.shutting_down:
                return None
            return await super()._async_interrupt_kernel()

    _KERNEL_MANAGER = SlicedPollKernelManager
    return _KERNEL_MANAGER


_ANSI = re.compile(r"\x1b\[[0-9;]*[A-Za-z]")
_CELL_LINE = re.compile(r"Cell In\[\d+\], line (\d+)")


def _first_error(nb, name=""):
    """(cell index, message) of the first error output in an executed notebook.

    The message names the notebook, the cell (1-based, counted in the source notebook:
    papermill's injected-parameters cell is not counted) and the line inside that cell:
    ``"02_fk.ipynb, cell 9, line 3: NameError: name 'x' is not defined"``.
    """
    number = 0
    for i, cell in enumerate(nb.cells):
        if "injected-parameters" not in cell.get("metadata", {}).get("tags", []):
            number += 1
        for out in cell.get("outputs", []):
            if out.get("output_type") == "error":
                trace = _ANSI.sub("", "\n".join(out.get("traceback", [])))
                line = _CELL_LINE.search(trace)
                where = f"cell {number}" + (f", line {line.group(1)}" if line else "")
                prefix = f"{name}, {where}" if name else where
                return i, f"{prefix}: {out.get('ename', 'Error')}: {out.get('evalue', '')}"
    return None, ""


class _PapermillNoise(logging.Filter):
    """Drop papermill's parameter-inference warnings: labkit parses the parameters cell with
    :mod:`ast` (:func:`notebook_parameters`) and has already checked the names, while papermill's
    line parser misreads ``port = "sim://?a=b"  # comment`` (two ``=``) and then calls the
    parameter unknown although its value is injected."""

    def filter(self, record):
        text = record.getMessage()
        return not (text.startswith("Unable to parse line") or text.startswith("Passed unknown parameter"))


def _quiet_papermill():
    for name in ("papermill", "papermill.translators"):
        log = logging.getLogger(name)
        if not any(isinstance(f, _PapermillNoise) for f in log.filters):
            log.addFilter(_PapermillNoise())


def execute_notebook(notebook, output, parameters=None, *, cwd=None, kernel_name="python3",
                     check_names=True, timeout=CELL_TIMEOUT) -> ExecutionResult:
    """Execute ``notebook`` in a fresh kernel and write the executed copy to ``output``.

    Parameters
    ----------
    notebook, output : str or Path
        Source notebook and where to write the executed notebook (folders are created).
    parameters : dict, optional
        Overrides injected after the ``parameters`` cell (name -> Python value).
    cwd : str or Path, optional
        Working directory of the kernel (default: the notebook's folder).
    kernel_name : str
        Jupyter kernel to start.
    check_names : bool
        Reject parameter names the notebook does not declare (with the valid names).
    timeout : float
        Seconds a single cell may run [s].

    Returns
    -------
    ExecutionResult
        ``ok=False`` (and the error) when a cell raised; the output is written either way.

    Raises
    ------
    LabkitError
        For a missing notebook or an unknown parameter name (nothing is executed).
    """
    with needs_extra("reports"):
        import nbformat
        import papermill
        from papermill.exceptions import PapermillExecutionError

    notebook, output = Path(notebook), Path(output)
    if not notebook.is_file():
        raise LabkitError(f"notebook not found: {notebook}")
    parameters = dict(parameters or {})
    if check_names and parameters:
        declared = notebook_parameters(notebook)
        unknown = sorted(set(parameters) - set(declared))
        if unknown:
            raise LabkitError(f"{notebook.name} has no parameter {', '.join(unknown)}; "
                              f"its parameters are: {', '.join(declared) or '(none)'}")
        check_parameter_types(notebook.name, declared, parameters)
    output.parent.mkdir(parents=True, exist_ok=True)
    _quiet_papermill()
    t0 = time.perf_counter()
    for start in range(1, KERNEL_STARTS + 1):
        try:
            papermill.execute_notebook(
                str(notebook), str(output), parameters=parameters, kernel_name=kernel_name,
                cwd=str(cwd or notebook.parent), progress_bar=False, log_output=False,
                request_save_on_cell_execute=False, execution_timeout=timeout,
                kernel_manager_class=kernel_manager_class(),
            )
        except PapermillExecutionError:
            pass  # the executed notebook (with the traceback) was written; described below
        except Exception as exc:  # kernel died, timeout, ...: still report, never stop the batch
            if start < KERNEL_STARTS and _kernel_never_started(exc):
                logging.getLogger(__name__).warning("%s: %s; starting a new kernel (no cell had run)",
                                                    notebook.name, exc)
                continue
            seconds = time.perf_counter() - t0
            if not output.exists():
                nb = nbformat.read(str(notebook), as_version=4)
                nbformat.write(nb, str(output))
            return ExecutionResult(notebook, output, False, seconds, f"{notebook.name}: {type(exc).__name__}: {exc}",
                                   None, parameters)
        break
    seconds = time.perf_counter() - t0
    from labkit.reports._portable import portable_notebook

    portable_notebook(output, notebook)  # no absolute path of this machine in the executed notebook
    cell, error = _first_error(nbformat.read(str(output), as_version=4), notebook.name)
    return ExecutionResult(notebook, output, cell is None, seconds, error, cell, parameters)


def _kernel_never_started(exc) -> bool:
    """Whether ``exc`` is jupyter_client's report of a kernel that died or stayed silent before its first
    reply (``wait_for_ready``): it never ran a cell, so a new kernel may run the notebook from the start."""
    text = str(exc)
    return isinstance(exc, RuntimeError) and ("before replying to kernel_info" in text or "didn't respond in" in text)


def chapter_of(notebook) -> int:
    """The notebook's chapter number in its lab's report (``labkit report``): its place in the lab folder.

    Parameters
    ----------
    notebook : str or os.PathLike
        A notebook ``<lab>/<name>.ipynb``.

    Returns
    -------
    int
        1 for the lab's first notebook (file order, as :func:`labkit.reports.build_report`).
    """
    notebook = Path(notebook).resolve()
    siblings = find_notebooks([notebook.parent])
    return siblings.index(notebook) + 1 if notebook in siblings else 1
