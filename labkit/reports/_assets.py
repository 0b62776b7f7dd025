"""The report's shared assets: MathJax, the widget manager and JupyterLab's stylesheet.

They are committed gzipped in ``labkit/reports/static`` (``tools/vendor-assets.sh``) and either
inlined into a page or written once into a reports folder's ``_static/`` and linked.
"""

from __future__ import annotations

import gzip
import json
import os
import re
from functools import lru_cache
from pathlib import Path

from labkit.exceptions import LabkitError, needs_extra

STATIC = Path(__file__).resolve().parent / "static"
_MATH = re.compile(r"(?<!\\)\$|\\\(|\\\[|\\begin\{|text/latex")


@lru_cache(maxsize=None)
def _asset(name: str) -> str:
    path = STATIC / f"{name}.gz"
    if not path.is_file():
        raise LabkitError(f"missing report asset {path}; run tools/vendor-assets.sh (needs npm) or reinstall labkit")
    return gzip.decompress(path.read_bytes()).decode("utf-8")


def _needs_math(nb) -> bool:
    state = nb.metadata.get("widgets", {}).get("application/vnd.jupyter.widget-state+json")
    if state and "text/latex" in json.dumps(state):
        return True
    for cell in nb.cells:
        if cell.cell_type == "markdown" and _MATH.search(cell.source):
            return True
        for out in cell.get("outputs", []):
            if "text/latex" in out.get("data", {}):
                return True
    return False


def _lab_css() -> str:
    """JupyterLab's stylesheet as nbconvert's ``lab`` template inlines it (index + light theme)."""
    with needs_extra("reports"):
        from jupyter_core.paths import jupyter_path

    for root in jupyter_path("nbconvert", "templates", "lab", "static"):
        if (Path(root) / "index.css").is_file():
            return "\n".join((Path(root) / f).read_text("utf-8") for f in ("index.css", "theme-light.css"))
    raise LabkitError("nbconvert's lab template (static/index.css) is missing; reinstall nbconvert")


def _shared_css(asset_dir, html_dir) -> str:
    """Write ``jupyterlab.css`` once into ``asset_dir``; its URL relative to ``html_dir``."""
    target = Path(asset_dir) / "jupyterlab.css"
    if not target.is_file():
        target.parent.mkdir(parents=True, exist_ok=True)
        tmp = target.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(_lab_css(), encoding="utf-8")
        os.replace(tmp, target)
    return os.path.relpath(target, html_dir).replace(os.sep, "/")


def _shared_asset(name, asset_dir, html_dir) -> str:
    """Write asset ``name`` once into ``asset_dir``; its URL relative to ``html_dir``."""
    asset_dir = Path(asset_dir)
    target = asset_dir / name
    if not target.is_file() or target.stat().st_mtime < (STATIC / f"{name}.gz").stat().st_mtime:
        asset_dir.mkdir(parents=True, exist_ok=True)
        tmp = target.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(_asset(name), encoding="utf-8")
        os.replace(tmp, target)  # atomic: parallel workers may write it at the same time
    return os.path.relpath(target, html_dir).replace(os.sep, "/")
