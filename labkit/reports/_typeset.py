"""Typeset once: a page as Chromium rendered it, without MathJax and the widget manager.

MathJax (2.2 MB) and the ipywidgets manager (2.0 MB) only turn the page's TeX into SVG and
its saved widget state into HTML, the same way at every view. :func:`static_page` lets
headless Chromium do that once and keeps the result: the SVG math and the widgets at their
saved values, with the page's other scripts (jshtml animations, the table fitting) intact.
"""

from __future__ import annotations

import re
from pathlib import Path

from labkit.exceptions import LabkitError

#: scripts that typeset math or render widgets (marked in the template), the widgets' saved state
_RENDER_SCRIPTS = re.compile(r"<script\b[^>]*\bdata-lk-render\b[^>]*>.*?</script>"
                             r'|<script\b[^>]*type="application/vnd\.jupyter\.widget-(?:state|view)\+json"[^>]*>.*?</script>',
                             re.DOTALL)


def static_page(dom, html_path, *, math=True, widgets=False, strip_all=False, css_dir=None) -> str:
    """The page ``html_path`` as Chromium rendered it (``dom``), without the scripts that rendered it.

    Parameters
    ----------
    dom : str
        The page's DOM after its scripts ran (``chromium --dump-dom``, see
        :func:`labkit.reports._render.rendered_dom`).
    html_path : str or os.PathLike
        The HTML page (MathJax and/or the widget manager inlined or linked) ``dom`` comes from.
    math, widgets : bool
        What the page has to render (checked in the result).
    strip_all : bool
        Remove every script (the lab report); default: only MathJax's and the widget manager's.
    css_dir : str or os.PathLike, optional
        Folder where the stylesheets the scripts added (the widget manager's, 0.7 MB with its
        icon fonts) are written once, named by content hash, and linked; default: kept inline.

    Returns
    -------
    str
        The rendered page (``<!DOCTYPE html>`` and the DOM); URLs of files next to the page
        stay relative.

    Raises
    ------
    LabkitError
        When MathJax typeset nothing or no widget was rendered.

    Examples
    --------
    >>> page = static_page('<html><head></head><body><mjx-container>x</mjx-container>'
    ...                    '<script data-lk-render>MathJax</script></body></html>', "r.html")
    >>> "<script" in page, "<mjx-container>" in page
    (False, True)
    """
    html_path = Path(html_path).resolve()
    if math and "<mjx-container" not in dom:
        raise LabkitError(f"MathJax did not typeset {html_path.name} (Chromium printed no math)")
    if widgets and "widget" not in dom:
        raise LabkitError(f"the widget manager rendered nothing in {html_path.name}")
    if strip_all:
        dom = re.sub(r"<script\b.*?</script>", "", dom, flags=re.DOTALL)
    else:
        dom = _RENDER_SCRIPTS.sub("", dom)
    # a script set src from a relative URL (animation frames): the DOM has the resolved file:// URL
    for folder, rel in ((html_path.parent, ""), (html_path.parent.parent, "../")):
        dom = dom.replace(f"file://{folder.as_posix()}/", rel)
    if css_dir is not None:
        dom = _link_added_styles(dom, Path(css_dir), html_path.parent)
    return "<!DOCTYPE html>\n" + dom


def _link_added_styles(dom, css_dir, html_dir):
    """Move the ``<style>`` elements scripts added to ``<head>`` (no attributes) into one shared file."""
    import hashlib
    import os

    head_end = dom.find("</head>")
    if head_end < 0:
        return dom
    head = dom[:head_end]
    # the page's own table fitting (it runs again on load) is not the scripts' shared CSS
    added = [c for c in re.findall(r"<style>(.*?)</style>", head, flags=re.DOTALL) if "data-lkfit" not in c]
    if not added:
        return dom
    css = "\n".join(added)
    target = css_dir / f"rendered-{hashlib.sha256(css.encode()).hexdigest()[:12]}.css"
    if not target.is_file():
        css_dir.mkdir(parents=True, exist_ok=True)
        tmp = target.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(css, encoding="utf-8")
        os.replace(tmp, target)  # atomic: parallel workers may write it at the same time
    href = os.path.relpath(target, html_dir).replace(os.sep, "/")
    first = [True]

    def repl(match):
        if "data-lkfit" in match.group(1):
            return ""  # added again when the page loads
        if first[0]:
            first[0] = False
            return f'<link rel="stylesheet" href="{href}">'
        return ""

    return re.sub(r"<style>(.*?)</style>", repl, head, flags=re.DOTALL) + dom[head_end:]
