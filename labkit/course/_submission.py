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
from pathlib import Path

from labkit.exceptions import InvalidSubmission, LabkitError, needs_extra
from labkit.course._safefs import UnsafeFile, read_file, read_tree, write_tree

__all__ = ["MAX_SUBMISSION_BYTES", "MAX_NOTEBOOK_BYTES", "MAX_CELLS", "MAX_DEPTH", "MAX_ENTRIES", "InvalidSubmission",
           "clean_text", "student_label", "copy_regular_files", "read_student_notebook", "error_detail"]

#: largest submission folder accepted [bytes]
MAX_SUBMISSION_BYTES = 50 * 2**20
#: largest student notebook read [bytes] (checked before it is parsed)
MAX_NOTEBOOK_BYTES = 16 * 2**20
#: most cells in a student notebook (checked before nbformat builds it)
MAX_CELLS = 2000
#: deepest folder level in a submission
MAX_DEPTH = 32
#: most files and folders in a submission
MAX_ENTRIES = 5000


_ANSI = re.compile(r"\x1b\[[0-9;]*[A-Za-z]")
_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f]")


def clean_text(text, limit=None) -> str:
    r"""Text a submission produced, safe for a terminal, a CSV, an Excel cell and UTF-8 files.

    Escape sequences and every other control character (C0, DEL, C1) go (a line break or tab
    becomes a space); characters that cannot be UTF-8 (surrogates from bytes that were not)
    appear as ``\udcXX``.

    Parameters
    ----------
    text : object
        Anything; its ``str``.
    limit : int, optional
        Most characters kept.

    Returns
    -------
    str

    Examples
    --------
    >>> clean_text("ok\x1b[2J\x07 done\r\nnext")
    'ok done  next'
    """
    text = str(text).encode("utf-8", "backslashreplace").decode("utf-8")
    text = _ANSI.sub("", text)
    text = _CONTROL.sub(lambda m: " " if m.group() in "\t\n\r" else "", text)
    return text if limit is None else text[:limit]


def student_label(name) -> str:
    r"""A submission folder's name as the gradebook shows it: as it is, with what could not be shown escaped.

    Bytes that are not UTF-8 (an unzip of a Latin-1 archive) appear as ``\xe9``, control
    characters (a CR, ESC) as ``\x0d``: visible, one line, and distinct names stay distinct.

    Parameters
    ----------
    name : str or bytes
        The folder's name as the file system gives it (``str`` with surrogate escapes, or bytes).

    Returns
    -------
    str

    Examples
    --------
    >>> print(student_label(b"caf\xe9\rx"))
    caf\xe9\x0dx
    """
    raw = name if isinstance(name, bytes) else os.fsencode(name)
    text = raw.decode("utf-8", "backslashreplace")
    return _CONTROL.sub(lambda m: f"\\x{ord(m.group()):02x}", text)
_CELL_LINE = re.compile(r"Cell In\[(\d+)\], line (\d+)")


def copy_regular_files(src: Path, dest: Path, limit=MAX_SUBMISSION_BYTES) -> None:
    """Copy the regular files under ``src`` into ``dest`` (no symlink followed or copied, nothing special).

    The walk is :func:`labkit.course._safefs.read_tree`'s: iterative, under folder descriptors, with
    caps on depth (:data:`MAX_DEPTH`), entries (:data:`MAX_ENTRIES`) and bytes (``limit``).

    Parameters
    ----------
    src, dest : pathlib.Path
        The submission and its working copy.
    limit : int
        Largest total size [bytes].

    Raises
    ------
    LabkitError
        If the files are over a cap (the message says which), or ``src`` is not a folder.
    """
    write_tree(read_tree(src, max_depth=MAX_DEPTH, max_entries=MAX_ENTRIES, max_bytes=limit), dest)


def read_student_notebook(folder: Path, name: str, *, max_bytes=MAX_NOTEBOOK_BYTES, max_cells=MAX_CELLS):
    """The student's notebook ``folder/name``, validated; its size and cell count capped before it is parsed.

    Parameters
    ----------
    folder : pathlib.Path
        The working copy (read through :func:`labkit.course._safefs.read_file`: never through a link).
    name : str
        The notebook's file name.
    max_bytes : int
        Largest notebook file [bytes].
    max_cells : int
        Most cells.

    Returns
    -------
    nbformat.NotebookNode

    Raises
    ------
    FileNotFoundError
        If it is not there.
    InvalidSubmission
        If it is not a regular file, is over a cap, or a cell is malformed.
    ValueError
        If it is not a valid notebook (not JSON, a cell without ``cell_type``, a ``source`` that is not text, ...).
    """
    import json

    with needs_extra("course"):
        import nbformat

    try:
        data = read_file(folder, name, max_bytes=max_bytes)
    except UnsafeFile as exc:
        raise InvalidSubmission(str(exc)) from None
    text = data.decode("utf-8", errors="strict")
    doc = json.loads(text)
    if not isinstance(doc, dict):
        raise InvalidSubmission(f"expected a notebook (a JSON object), got a JSON {type(doc).__name__}")
    cells = doc.get("cells")
    if isinstance(cells, list) and len(cells) > max_cells:
        raise InvalidSubmission(f"expected at most {max_cells} cells, got {len(cells)}")
    del doc
    nb = nbformat.reads(text, as_version=4)
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
    return clean_text(f"{ename}: {evalue or '(no message)'} in {where}", 400)
