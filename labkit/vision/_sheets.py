"""Printable marker and board sheets: PDFs at true size (:func:`marker_sheet`, :func:`board_sheet`).

The page is drawn by matplotlib at exact physical size (inches = metres / 0.0254)
with the image placed in axes that span exactly the printed side, so a sheet
printed at 100 % ("actual size", no "fit to page") has markers of the stated
size; a 10 cm check line on the sheet lets you verify it with a ruler.
"""

from __future__ import annotations

import numpy as np

from labkit.exceptions import OptionError
from labkit.validation import as_count, as_number, as_option, as_path
from labkit.vision._boards import CharucoBoard, Checkerboard
from labkit.vision._families import as_length, family_info, marker_texture, texture_extent

__all__ = ["marker_sheet", "board_sheet", "PAPER"]

#: paper sizes (width, height) [m]
PAPER = {"a4": (0.210, 0.297), "letter": (0.2159, 0.2794)}
_INCH = 0.0254


def _page(paper):
    from matplotlib.figure import Figure

    w, h = PAPER[as_option(paper, PAPER, "paper")]
    return Figure(figsize=(w / _INCH, h / _INCH)), w, h


def _place(fig, image, left, bottom, width, height, page_w, page_h):
    ax = fig.add_axes([left / page_w, bottom / page_h, width / page_w, height / page_h])
    ax.imshow(image, cmap="gray", vmin=0, vmax=1, interpolation="none", aspect="auto")  # embedded as is, not resampled
    ax.set_axis_off()
    return ax


def _check_line(fig, page_w, page_h, text):
    ax = fig.add_axes([0, 0, 1, 1], facecolor="none")
    ax.set_xlim(0, page_w)
    ax.set_ylim(0, page_h)
    ax.set_axis_off()
    ax.plot([0.02, 0.12], [0.012, 0.012], color="black", lw=0.8)
    ax.text(0.02, 0.016, "this line is 100 mm long when printed at actual size (100 %)", fontsize=6)
    ax.text(0.02, page_h - 0.012, text, fontsize=7, va="top")


def marker_sheet(path, ids, size, family="tag36h11", *, paper="a4", gap=0.01):
    """Write a PDF of markers at true size (several per page when they fit).

    Parameters
    ----------
    path : str or os.PathLike
        The PDF to write.
    ids : int or sequence of int
        Marker ids.
    size : float
        Side of the black square [m].
    family : str
    paper : {"a4", "letter"}
    gap : float
        Space between the markers' quiet zones [m].

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    OptionError
        A marker does not fit on the paper, or an unknown family, id or paper; a size or gap that is not a
        finite length, a path that is not one.
    """
    from matplotlib.backends.backend_pdf import PdfPages

    path = as_path(path, "the PDF to write")
    info = family_info(family)
    what = f"ids as {family} ids 0..{info.count - 1} (one or a sequence)"
    try:
        ids = [ids] if np.ndim(ids) == 0 else list(ids)
    except (TypeError, ValueError):  # a ragged list or an object numpy will not size
        raise OptionError(f"expected {what}, got {ids!r}") from None
    if not ids:
        raise OptionError(f"expected {what}, got none")
    ids = [as_count(i, f"{family} ids", maximum=info.count - 1) for i in ids]
    size = as_length(size, "size (the black square)")
    gap = as_number(gap, "gap", unit="m", minimum=0.0, error=OptionError)
    side = texture_extent(family, size)
    fig, w, h = _page(paper)
    margin = 0.015
    cols = int((w - 2 * margin + gap) // (side + gap))
    rows = int((h - 2 * margin - 0.02 + gap) // (side + gap + 0.006))
    if cols < 1 or rows < 1:
        raise OptionError(f"expected a marker that fits on {paper} paper, got {side * 1e3:.0f} mm with its border")
    with PdfPages(path) as pdf:
        for start in range(0, len(ids), cols * rows):
            fig, w, h = _page(paper)
            for k, mid in enumerate(ids[start:start + cols * rows]):
                r, c = divmod(k, cols)
                left = margin + c * (side + gap)
                bottom = h - margin - 0.02 - (r + 1) * (side + gap + 0.006) + gap
                _place(fig, marker_texture(family, mid), left, bottom, side, side, w, h)
                fig.text((left + side / 2) / w, (bottom - 0.004) / h, f"{family} id {mid}", fontsize=5, ha="center")
            _check_line(fig, w, h, f"{family}, black square {size * 1e3:g} mm")
            pdf.savefig(fig)
    return path


def board_sheet(path, board, *, paper="a4"):
    """Write a PDF of a calibration board at true size.

    Parameters
    ----------
    path : str or os.PathLike
    board : Checkerboard or CharucoBoard
    paper : {"a4", "letter"}

    Returns
    -------
    pathlib.Path

    Raises
    ------
    OptionError
        The board does not fit on the paper, or is not a board; an unknown paper or a path that is not one.
    """
    path = as_path(path, "the PDF to write")
    if not isinstance(board, (Checkerboard, CharucoBoard)):
        raise OptionError(f"expected board as a Checkerboard or a CharucoBoard, got {board!r}")
    fig, w, h = _page(paper)
    bw, bh = board.extent
    if bw > w - 0.01 or bh > h - 0.04:
        raise OptionError(f"expected a board that fits on {paper} paper, got {bw * 1e3:.0f} x {bh * 1e3:.0f} mm")
    _place(fig, board.texture(), (w - bw) / 2, (h - bh) / 2, bw, bh, w, h)
    _check_line(fig, w, h, f"{type(board).__name__}: {board}")
    fig.savefig(path, format="pdf")
    return path
