"""Compact raster figures and animation frames of executed notebooks (reports' size budget).

matplotlib writes RGBA PNGs with a few thousand colours (antialiasing), and a jshtml animation
holds every frame as such a PNG. :func:`compact_notebook` re-encodes them in place, once, right
after a notebook is executed, so the executed copy, its HTML and PDF and the lab report all carry
the small version:

* a figure (few colours: plots, drawings) becomes a palette PNG - 256 colours picked from the
  image without dithering, alpha flattened on white - about half the bytes, not visibly different;
* a photograph-like image (many colours, e.g. a camera frame) becomes a JPEG (quality 88,
  no chroma subsampling), which the PDF also embeds as it is;
* anything wider than :data:`MAX_WIDTH_PX` (174 mm of text at 200 dpi) is scaled down to it;
* an image only gets the new encoding when it is smaller than the original.

Example
-------
>>> from labkit.reports._images import compact_image
>>> import base64, io
>>> from PIL import Image
>>> buf = io.BytesIO(); Image.new("RGBA", (64, 32), (255, 0, 0, 255)).save(buf, "PNG")
>>> compact_image(buf.getvalue())[0]
'image/png'
"""

from __future__ import annotations

import base64
import io
import re
from pathlib import Path

from labkit.exceptions import needs_extra

__all__ = ["MAX_WIDTH_PX", "ASSET_KEY", "compact_image", "compact_frames", "compact_notebook", "compact_notebook_file",
           "externalize", "internalize"]

#: widest raster image kept [px]: the 174 mm text width of the printed report at 200 dpi
MAX_WIDTH_PX = 1370
#: more distinct colours than this: a photograph (JPEG), else a figure (palette PNG)
PHOTO_COLOURS = 20000
#: JPEG quality of photograph-like images
JPEG_QUALITY = 88
_FRAME = re.compile(r"data:image/png;base64,([A-Za-z0-9+/=\\\n]+)")


def _flat(image):
    from PIL import Image

    if image.mode in ("RGBA", "LA", "P"):
        image = image.convert("RGBA")
        flat = Image.new("RGB", image.size, "white")
        flat.paste(image, mask=image.getchannel("A"))
        return flat
    return image.convert("RGB")


def compact_image(data: bytes, *, max_width=MAX_WIDTH_PX):
    """The smaller encoding of one raster image (PNG or JPEG bytes).

    Parameters
    ----------
    data : bytes
        A PNG or JPEG file's bytes.
    max_width : int
        Widest image kept [px]; a wider one is scaled down (aspect kept).

    Returns
    -------
    (str, bytes)
        MIME type (``"image/png"`` or ``"image/jpeg"``) and the bytes: the original when
        re-encoding would not make it smaller or Pillow cannot read it.
    """
    try:
        from PIL import Image

        image = Image.open(io.BytesIO(data))
        image.load()
        original = "image/jpeg" if image.format == "JPEG" else "image/png"
    except Exception:  # not an image Pillow reads: keep it as it is
        return "image/png", data
    if image.width <= max_width and (image.format == "JPEG" or image.mode in ("P", "L")):
        return original, data  # compact already (a palette PNG written here, or a JPEG)
    rgb = _flat(image)
    if rgb.width > max_width:
        rgb = rgb.resize((max_width, round(rgb.height * max_width / rgb.width)), Image.LANCZOS)
    colours = rgb.getcolors(PHOTO_COLOURS)
    out = io.BytesIO()
    if colours is None:  # a photograph
        try:
            rgb.save(out, "JPEG", quality=JPEG_QUALITY, subsampling=0, optimize=True)
        except OSError:  # Pillow's buffer too small for an optimised JPEG of a noisy image
            out = io.BytesIO()
            rgb.save(out, "JPEG", quality=JPEG_QUALITY, subsampling=0)
        mime = "image/jpeg"
    else:
        # <= 256 colours: exact; more (antialiased plot lines): the 256 most representative
        image8 = rgb.quantize(min(256, len(colours)), method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
        image8.save(out, "PNG", optimize=True)
        mime = "image/png"
    small = out.getvalue()
    if len(small) >= len(data):
        return original, data
    return mime, small


def _b64(data: bytes) -> str:
    return base64.b64encode(data).decode("ascii")


def compact_frames(html: str) -> str:
    """A jshtml animation (matplotlib ``to_jshtml``) with every PNG frame re-encoded (:func:`compact_image`).

    Parameters
    ----------
    html : str
        The animation's HTML (frames as ``data:image/png;base64,...`` strings in its script).

    Returns
    -------
    str
    """

    def frame(m):
        raw = m.group(1).replace("\\n", "").replace("\n", "").replace("\\", "")
        try:
            data = base64.b64decode(raw)
        except ValueError:
            return m.group(0)
        mime, small = compact_image(data)
        return f"data:{mime};base64,{_b64(small)}"

    return _FRAME.sub(frame, html)


def compact_notebook(nb) -> int:
    """Re-encode the notebook's PNG figures and jshtml animation frames in place.

    Parameters
    ----------
    nb : nbformat.NotebookNode
        An executed notebook.

    Returns
    -------
    int
        Bytes saved (of the base64 text).
    """
    saved = 0
    for cell in nb.cells:
        for out in cell.get("outputs", []):
            data = out.get("data", {})
            if "image/png" in data:
                text = data["image/png"] if isinstance(data["image/png"], str) else "".join(data["image/png"])
                mime, small = compact_image(base64.b64decode(text))
                new = _b64(small)
                if len(new) < len(text):
                    del data["image/png"]
                    data[mime] = new
                    saved += len(text) - len(new)
            html = data.get("text/html")
            if html is not None:
                html = html if isinstance(html, str) else "".join(html)
                if "data:image/png;base64," in html and "<table" not in html:
                    new = compact_frames(html)
                    saved += len(html) - len(new)
                    data["text/html"] = new
    return saved


def compact_notebook_file(path) -> int:
    """:func:`compact_notebook` on a notebook file (rewritten in place).

    Parameters
    ----------
    path : str or os.PathLike
        An executed ``.ipynb``.

    Returns
    -------
    int
        Bytes saved.
    """
    with needs_extra("reports"):
        import nbformat

    nb = nbformat.read(str(path), as_version=4)
    saved = compact_notebook(nb)
    if saved:
        nbformat.write(nb, str(path))
    return saved


#: output metadata key of a figure written to a file by :func:`externalize`
ASSET_KEY = "labkit-asset"
#: images smaller than this stay inline [bytes]
INLINE_BYTES = 4096
_DATA_URI = re.compile(r"data:(image/(?:png|jpeg|webp));base64,([A-Za-z0-9+/=\\\n]+)")
_EXT = {"image/png": "png", "image/jpeg": "jpg", "image/webp": "webp"}
_MIME = {v: k for k, v in _EXT.items()}


def _write_asset(folder, subdir, mime, data: bytes) -> str:
    import hashlib

    name = f"{hashlib.sha1(data).hexdigest()[:16]}.{_EXT[mime]}"
    target = Path(folder) / subdir / name
    if not target.is_file():
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(data)
    return f"{subdir}/{name}"


def externalize(nb, folder, subdir) -> int:
    """Write the notebook's figures and animation frames once as files; the outputs link them.

    A figure output (``image/png``/``image/jpeg`` of at least :data:`INLINE_BYTES`) becomes an
    ``<img src="SUBDIR/<hash>.png">`` HTML output (the original MIME type kept in its
    metadata under :data:`ASSET_KEY`); a jshtml animation's frames become relative URLs of
    such files. The report's HTML and the executed notebook beside it then share one copy;
    :func:`internalize` puts the images back.

    Parameters
    ----------
    nb : nbformat.NotebookNode
        Notebook (changed in place).
    folder : str or os.PathLike
        The folder the HTML and the notebook are written to.
    subdir : str
        Folder for the files, relative to ``folder`` (e.g. ``"02_fk_assets"``).

    Returns
    -------
    int
        Number of images written or linked.
    """
    count = 0
    for cell in nb.cells:
        for out in cell.get("outputs", []):
            data = out.get("data", {})
            mime = next((m for m in ("image/png", "image/jpeg") if m in data), None)
            if mime:
                raw = base64.b64decode(_joined(data[mime]))
                if len(raw) < INLINE_BYTES:
                    continue
                src = _write_asset(folder, subdir, mime, raw)
                del data[mime]
                data["text/html"] = f'<img src="{src}" alt="figure" class="labkit-figure">'
                out.setdefault("metadata", {})[ASSET_KEY] = {"mime": mime, "src": src}
                count += 1
                continue
            html = data.get("text/html")
            if html is not None and "<table" not in _joined(html) and "data:image/" in _joined(html):
                def frame(m):
                    nonlocal count
                    count += 1
                    raw = base64.b64decode(m.group(2).replace("\\n", "").replace("\n", "").replace("\\", ""))
                    return _write_asset(folder, subdir, m.group(1), raw)

                data["text/html"] = _DATA_URI.sub(frame, _joined(html))
                out.setdefault("metadata", {})[ASSET_KEY] = {"frames": subdir}
    return count


def internalize(nb, folder) -> int:
    """Undo :func:`externalize`: read the linked figures and frames back into the outputs.

    Parameters
    ----------
    nb : nbformat.NotebookNode
        Notebook (changed in place), e.g. an executed notebook of ``labkit render``.
    folder : str or os.PathLike
        The notebook's folder (the links are relative to it).

    Returns
    -------
    int
        Number of images read back; a missing file leaves its link.
    """
    count = 0
    for cell in nb.cells:
        for out in cell.get("outputs", []):
            meta = out.get("metadata", {}).get(ASSET_KEY)
            if not meta:
                continue
            data = out["data"]
            if "mime" in meta:
                path = Path(folder) / meta["src"]
                if path.is_file():
                    data.pop("text/html", None)
                    data[meta["mime"]] = _b64(path.read_bytes())
                    del out["metadata"][ASSET_KEY]
                    count += 1
                continue
            sub = re.escape(meta["frames"])

            def frame(m):
                nonlocal count
                path = Path(folder) / m.group(0)
                if not path.is_file():
                    return m.group(0)
                count += 1
                return f"data:{_MIME[path.suffix[1:]]};base64,{_b64(path.read_bytes())}"

            data["text/html"] = re.sub(sub + r"/[0-9a-f]{16}\.(?:png|jpg|webp)", frame, _joined(data["text/html"]))
            del out["metadata"][ASSET_KEY]
    return count


def _joined(value) -> str:
    return value if isinstance(value, str) else "".join(value)
