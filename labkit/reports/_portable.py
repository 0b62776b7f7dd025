"""No machine path in what labkit writes: executed notebooks, kernel logs and the index.

papermill records the absolute input and output paths of a run (``metadata.papermill``), and
a notebook's outputs print the folders it writes to. :func:`portable_notebook` rewrites an
executed notebook so that it names the source by its lab (``<lab>/<name>.ipynb``) and every
absolute folder of the machine relative to the executed notebook (``./<name>_files``) or by
a short name (``<python>``, ``~``, ``<tmp>/``); :func:`portable_text` does the same for a
plain text file (the kernel's log, ``index.json``).
"""

from __future__ import annotations

import html as _html
import json
from pathlib import Path

from labkit.reports._document import _default_roots, scrub_paths


def _plain_roots(*folders):
    """The roots of :func:`labkit.reports._document._default_roots` with plain-text names."""
    return [(root, _html.unescape(rep)) for root, rep in _default_roots(*folders)]


def portable_text(path, *folders) -> Path:
    """Rewrite the text file ``path`` with the machine's absolute paths made relative.

    Parameters
    ----------
    path : str or os.PathLike
        A text file labkit wrote (kernel log, JSON).
    *folders : str or os.PathLike
        Folders written as ``.`` (besides the repository and the working folder).

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    path = Path(path)
    text = path.read_text("utf-8", errors="replace")
    scrubbed = scrub_paths(text, _plain_roots(*(str(f) for f in folders)))
    if scrubbed != text:
        path.write_text(scrubbed, encoding="utf-8")
    return path


def portable_notebook(output, source) -> Path:
    """Rewrite the executed notebook ``output`` without absolute paths of this machine.

    Parameters
    ----------
    output : str or os.PathLike
        The executed notebook papermill wrote.
    source : str or os.PathLike
        The notebook it was executed from (``.../<lab>/<name>.ipynb``).

    Returns
    -------
    pathlib.Path
        ``output``: ``metadata.papermill.input_path`` is ``<lab>/<name>.ipynb``, ``output_path``
        the file's name, and the folder of ``output`` (and the source's, the repository, the
        working folder) is ``.`` in parameters and outputs; site-packages, home and temporary
        folders are ``<python>``, ``~`` and ``<tmp>/``.
    """
    output, source = Path(output).resolve(), Path(source).resolve()
    nb = json.loads(output.read_text("utf-8"))
    pm = nb.get("metadata", {}).get("papermill")
    if isinstance(pm, dict):
        pm["input_path"] = f"{source.parent.name}/{source.name}"
        pm["output_path"] = output.name
    text = json.dumps(nb, indent=1, ensure_ascii=False)
    # the executed notebook's folder first (a parameter output_dir = <folder>/<name>_files reads ./<name>_files)
    roots = [(str(output.parent), ".")] + _plain_roots(str(source.parent))
    roots = [(json.dumps(r)[1:-1], json.dumps(rep)[1:-1]) for r, rep in roots]  # as they appear in JSON
    output.write_text(scrub_paths(text, roots) + "\n", encoding="utf-8")
    return output
