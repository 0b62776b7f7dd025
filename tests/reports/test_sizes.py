"""The reports' size budget (issue 22: the seed set <= 25 MB): figures and animation frames are
re-encoded small, written once as files shared by the HTML and the executed notebook, and read
back by the lab report. Checked on a matplotlib jshtml animation made here (no kernel: fast) and,
by :func:`assert_images_within_budget`, on the real animations of the lab notebooks that
``tests/reports/test_notebooks.py`` executes anyway."""

import base64
import io
import re
from pathlib import Path

from conftest import require

#: mean bytes of a jshtml animation frame after compacting: the seed labs' 157 frames in 4
#: animations are 7.6-10.8 kB on average for the 2-D arms (seed004) and 16.6 kB for the PUMA in 3-D
#: (seed002/04); at this budget 160 frames take under 3 MB of the 25 MB
FRAME_BUDGET = 18_000
FRAMES = 12


def assert_images_within_budget(nb, folder, name):
    """labkit render's image path on an executed notebook: every animation frame within
    :data:`FRAME_BUDGET` on average, every image stored once (one file linked by the HTML and the
    executed notebook, none inlined in either). Returns the number of frames checked."""
    nbformat = require("nbformat")
    from labkit.reports import export_html
    from labkit.reports._images import compact_notebook, externalize

    folder = Path(folder)
    compact_notebook(nb)
    html = export_html(nb, folder / f"{name}.html", asset_dir=folder / "_static",
                       figures=f"{name}_assets").read_text("utf-8")
    externalize(nb, folder, f"{name}_assets")
    nbformat.write(nb, str(folder / f"{name}.ipynb"))
    stored = (folder / f"{name}.ipynb").read_text("utf-8")
    assets = sorted((folder / f"{name}_assets").iterdir()) if (folder / f"{name}_assets").is_dir() else []
    assert "data:image" not in html and "data:image" not in stored, "an image inlined besides its file"
    for path in assets:  # one file, linked by both
        link = f"{name}_assets/{path.name}"
        assert link in html and link in stored, f"{link} not shared by the HTML and the executed notebook"
    frames = sorted(set(re.findall(rf"frames\[\d+\] = \"({re.escape(name)}_assets/[^\"]+)\"", html)))
    if frames:
        size = sum((folder / f).stat().st_size for f in frames) / len(frames)
        assert size <= FRAME_BUDGET, f"{name}: {size:.0f} bytes per animation frame (budget {FRAME_BUDGET})"
    return len(frames)


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
    from labkit.reports._images import internalize

    nb = _animation_notebook()
    original = len(nbformat.writes(nb))
    assert len(_frames(nb.cells[1].outputs[0].data["text/html"])) == FRAMES
    # labkit render's layout: compacted, the HTML and the executed notebook link one copy of each image
    assert assert_images_within_budget(nb, tmp_path, "anim") == FRAMES
    html = (tmp_path / "anim.html").read_text("utf-8")
    stored = (tmp_path / "anim.ipynb").read_text("utf-8")
    assets = sorted((tmp_path / "anim_assets").iterdir())
    assert len(assets) == FRAMES + 1  # every frame and the still figure, once
    assert all(f.startswith("anim_assets/") for f in _frames(html))
    assert "Figure 1</span>: The arm moving" in html and "Figure 2</span>" in html and str(tmp_path) not in html + stored
    images = sum(p.stat().st_size for p in assets)
    assert images + len(stored) < 0.5 * original, (images, len(stored), original)  # palette PNG frames
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
