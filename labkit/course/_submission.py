r"""A submission's files: copied without following a link, read and validated, errors located.

Example
-------
>>> from labkit.course._submission import error_detail
>>> cell = {"id": "work", "source": "x = 1\nraise ValueError('no')", "outputs": [{"output_type": "error",
...         "ename": "ValueError", "evalue": "no", "traceback": ["Cell In[3], line 2"]}]}
>>> print(error_detail(cell, 4))
ValueError: no in cell 5 (id work), line 2: raise ValueError('no')
"""

from __future__ import annotations

import os
import re
import shutil
import stat
from pathlib import Path

from labkit.exceptions import LabkitError, needs_extra

__all__ = ["MAX_SUBMISSION_BYTES", "InvalidSubmission", "copy_regular_files", "read_student_notebook", "error_detail"]

#: largest submission folder accepted [bytes]
MAX_SUBMISSION_BYTES = 50 * 2**20


class InvalidSubmission(LabkitError, ValueError):
    """A student's notebook is not one labkit can grade (not a file, not a notebook, a malformed cell)."""


_ANSI = re.compile(r"\x1b\[[0-9;]*[A-Za-z]")
_CELL_LINE = re.compile(r"Cell In\[(\d+)\], line (\d+)")


def copy_regular_files(src: Path, dest: Path, limit=MAX_SUBMISSION_BYTES) -> None:
    """Copy the regular files under ``src`` into ``dest`` (no symlink followed or copied, nothing special).

    Parameters
    ----------
    src, dest : pathlib.Path
        The submission and its working copy.
    limit : int
        Largest total size [bytes].

    Raises
    ------
    LabkitError
        If the files add up to more than ``limit``.
    """
    total = 0
    for dirpath, dirnames, filenames in os.walk(src, followlinks=False):
        rel = Path(dirpath).relative_to(src)
        dirnames[:] = [d for d in dirnames if d != ".ipynb_checkpoints" and not os.path.islink(os.path.join(dirpath, d))]
        for name in filenames:
            p = Path(dirpath) / name
            st = os.lstat(p)
            if not stat.S_ISREG(st.st_mode):
                continue
            total += st.st_size
            if total > limit:
                raise LabkitError(f"expected at most {limit} bytes in the submission {src.name}, got more")
            (dest / rel).mkdir(parents=True, exist_ok=True)
            fd = os.open(p, os.O_RDONLY | os.O_NOFOLLOW)
            with os.fdopen(fd, "rb") as fin, open(dest / rel / name, "wb") as fout:
                shutil.copyfileobj(fin, fout)


def read_student_notebook(path: Path):
    """The student's notebook, validated.

    Parameters
    ----------
    path : pathlib.Path
        The notebook in the working copy (a regular file, never followed through a link).

    Returns
    -------
    nbformat.NotebookNode

    Raises
    ------
    FileNotFoundError
        If it is not there.
    InvalidSubmission
        If it is not a regular file, or a cell is malformed.
    ValueError
        If it is not a valid notebook (not JSON, a cell without ``cell_type``, a ``source`` that is not text, ...).
    """
    with needs_extra("course"):
        import nbformat

    st = os.lstat(path)
    if not stat.S_ISREG(st.st_mode):
        raise InvalidSubmission("not a regular file")
    nb = nbformat.reads(path.read_text(encoding="utf-8", errors="strict"), as_version=4)
    nbformat.validate(nb)
    for cell in nb.cells:
        if cell.get("cell_type") not in ("code", "markdown", "raw") or not isinstance(cell.get("source"), str):
            raise InvalidSubmission(f"cell {cell.get('id')!r}: expected a cell_type of code, markdown or raw and a text "
                                    f"source, got {cell.get('cell_type')!r} and {type(cell.get('source')).__name__}")
    return nb


def error_detail(cell, index) -> str:
    """``'<Type>: <message> in cell <n> (id <id>), line <l>: <text>'`` for a cell's error output.

    Parameters
    ----------
    cell : dict
        An executed code cell with an error output.
    index : int
        Its position in the notebook (0-based).

    Returns
    -------
    str
    """
    err = next(o for o in cell.get("outputs", []) if o.get("output_type") == "error")
    ename, evalue = str(err.get("ename", "Error")), str(err.get("evalue", "")).strip()
    text = _ANSI.sub("", "\n".join(str(t) for t in err.get("traceback", [])))
    line = None
    for match in _CELL_LINE.finditer(text):
        line = int(match.group(2))
    where = f"cell {index + 1} (id {cell.get('id')})"
    if line is not None:
        lines = str(cell.get("source", "")).splitlines()
        code = lines[line - 1].strip() if 0 < line <= len(lines) else ""
        where += f", line {line}" + (f": {code}" if code else "")
        if ename == "NotImplementedError" and "NotImplementedError" in code:
            evalue = evalue or "the stub of the student version is still there (this step is not done)"
    return f"{ename}: {evalue or '(no message)'} in {where}"[:400]
