"""The reports' size budget (issue 22: the seed set <= 25 MB): figures and animation frames are
re-encoded small, written once as files shared by the HTML and the executed notebook, and read
back by the lab report. Checked on a matplotlib jshtml animation made here (no kernel: fast)."""

import base64
import io
import re

from conftest import require

#: a jshtml animation frame (600 x 500 px, a line drawing) after compacting [bytes]
FRAME_BUDGET = 12_000
FRAMES = 12


def _animation_notebook():
    nbformat = require("nbformat")
    matplotlib = require("matplotlib")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from matplotlib.animation import FuncAnimation

    fig, ax = plt.subplots(figsize=(6, 5))
    ax.set_xlim(-1.2, 1.2), ax.set_ylim(-1.2, 1.2), ax.grid(True)
    line, = ax.plot([], [], "o-", lw=3)
    trail, = ax.plot([], [], "-", color="C1", alpha=0.5)
    t = np.linspace(0, 2 * np.pi, FRAMES)

    def draw(k):
        x, y = np.cos(t[k]) * np.r_[0, 0.6, 1], np.sin(t[k]) * np.r_[0, 0.6, 1] + 0.1 * np.r_[0, 1, 0]
        line.set_data(x, y)
        trail.set_data(np.cos(t[:k + 1]), np.sin(t[:k + 1]))
        return line, trail

    html = FuncAnimation(fig, draw, frames=FRAMES).to_jshtml()
    ax.set_title("the arm")  # the still figure differs from the last frame (identical ones are stored once)
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_markdown_cell("# Animation\n\n@fig-anim and @fig-still."),
                nbformat.v4.new_code_cell("#| label: fig-anim\n#| fig-cap: The arm moving\nHTML(anim.to_jshtml())"),
                nbformat.v4.new_code_cell("#| label: fig-still\n#| fig-cap: The arm\nfig")]
    nb.cells[1].outputs = [nbformat.v4.new_output("display_data", {"text/html": html, "text/plain": "<HTML>"})]
    nb.cells[2].outputs = [nbformat.v4.new_output("display_data", {
        "image/png": base64.b64encode(buf.getvalue()).decode(), "text/plain": "<Figure>"})]
    return nb


def _frames(html):
    return re.findall(r"frames\[\d+\] = \"([^\"]{0,60})", html)


def test_animation_frames_are_small_stored_once_and_read_back(tmp_path):
    nbformat = require("nbformat")
    from labkit.reports import export_html
    from labkit.reports._images import compact_notebook, externalize, internalize

    nb = _animation_notebook()
    original = len(nbformat.writes(nb))
    assert len(_frames(nb.cells[1].outputs[0].data["text/html"])) == FRAMES
    compact_notebook(nb)
    compacted = len(nbformat.writes(nb))
    assert compacted < 0.6 * original, (compacted, original)  # PNG frames of a drawing: palette PNGs
    # labkit render's layout: the HTML and the executed notebook link one copy of each image
    html = export_html(nb, tmp_path / "anim.html", asset_dir=tmp_path / "_static", chapter=3,
                       figures="anim_assets").read_text("utf-8")
    externalize(nb, tmp_path, "anim_assets")
    nbformat.write(nb, str(tmp_path / "anim.ipynb"))
    assets = sorted((tmp_path / "anim_assets").iterdir())
    assert len(assets) == FRAMES + 1  # every frame and the still figure, once
    assert max(p.stat().st_size for p in assets[:-1] if p.name) <= FRAME_BUDGET * 2
    frames_bytes = sum(p.stat().st_size for p in assets) - max(p.stat().st_size for p in assets)
    assert frames_bytes <= FRAME_BUDGET * FRAMES, frames_bytes
    assert all(f.startswith("anim_assets/") for f in _frames(html)) and "data:image" not in html
    assert "Figure 3.1" in html and "Figure 3.2" in html and str(tmp_path) not in html
    stored = (tmp_path / "anim.ipynb").read_text("utf-8")
    total = len(stored) + len(html) + sum(p.stat().st_size for p in assets)
    assert total < 0.5 * 2 * original, (total, original)  # was: every frame in the notebook and in the HTML
    assert "data:image" not in stored and str(tmp_path) not in stored
    # the lab report reads the executed notebook back with its images inside
    back = nbformat.read(str(tmp_path / "anim.ipynb"), as_version=4)
    assert internalize(back, tmp_path) == FRAMES + 1
    frames = _frames(back.cells[1].outputs[0].data["text/html"])
    assert len(frames) == FRAMES and all(f.startswith("data:image/png;base64,") for f in frames)
    assert "image/png" in back.cells[2].outputs[0].data


def test_compact_image_keeps_size_colours_and_shrinks(tmp_path):
    require("PIL")
    import numpy as np
    from PIL import Image

    from labkit.reports._images import MAX_WIDTH_PX, compact_image

    # a plot-like image (white, antialiased lines): palette PNG, same pixels to within antialiasing
    yy, xx = np.mgrid[0:300, 0:800]
    dist = np.abs(yy - 150 - 100 * np.sin(xx / 60.0))
    alpha = np.clip(2.0 - dist, 0, 1)[..., None]
    plot = (255 * (1 - alpha) + alpha * np.array([31, 119, 180])).astype(np.uint8)
    buf = io.BytesIO()
    Image.fromarray(plot).convert("RGBA").save(buf, "PNG")
    mime, small = compact_image(buf.getvalue())
    back = np.asarray(Image.open(io.BytesIO(small)).convert("RGB"), dtype=float)
    assert mime == "image/png" and len(small) < len(buf.getvalue())
    assert back.shape == plot.shape and np.abs(back - plot).max() <= 24
    assert compact_image(small) == ("image/png", small)  # compact already: unchanged
    # a photograph (noise) wider than the print width: JPEG at the print width
    rng = np.random.default_rng(1)
    photo = rng.integers(0, 255, (400, 2000, 3), dtype=np.uint8)
    buf = io.BytesIO()
    Image.fromarray(photo).save(buf, "PNG")
    mime, small = compact_image(buf.getvalue())
    assert mime == "image/jpeg" and Image.open(io.BytesIO(small)).width == MAX_WIDTH_PX
