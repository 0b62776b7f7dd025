"""Printable sheets are PDFs at true size; the CLI writes them."""

import re

from labkit.cli import main
from labkit.vision import CharucoBoard, board_sheet


def _page_size_pt(pdf_bytes):
    m = re.search(rb"/MediaBox \[\s*0 0 ([\d.]+) ([\d.]+)\s*\]", pdf_bytes)
    return float(m.group(1)), float(m.group(2))


def test_marker_sheet_from_the_cli_is_an_a4_pdf(tmp_path):
    out = tmp_path / "markers.pdf"
    assert main(["vision", "marker", "0", "1", "--size", "40", "-o", str(out)]) == 0
    data = out.read_bytes()
    assert data.startswith(b"%PDF")
    w, h = _page_size_pt(data)
    assert abs(w / 72 * 25.4 - 210) < 0.5 and abs(h / 72 * 25.4 - 297) < 0.5


def test_a_board_too_big_for_the_paper_is_refused(tmp_path):
    assert main(["vision", "board", "--columns", "12", "--square", "30", "-o", str(tmp_path / "b.pdf")]) == 2
    assert board_sheet(tmp_path / "ok.pdf", CharucoBoard(5, 4, 0.03, 0.022)).exists()


def test_cli_detect_prints_the_pose_of_a_rendered_marker(tmp_path, capsys):
    import cv2
    import numpy as np

    from labkit.vision import Camera, VirtualCamera

    cam = Camera.pinhole(900.0, (640, 480))
    cam.save(tmp_path / "cam.toml")
    pose = np.eye(4)
    pose[:3, :3] = [[1, 0, 0], [0, -0.866, -0.5], [0, 0.5, -0.866]]
    pose[:3, 3] = [0.02, -0.01, 0.45]
    cv2.imwrite(str(tmp_path / "shot.png"), VirtualCamera(cam, noise=1.0).render_markers({4: pose}, size=0.05))
    assert main(["vision", "detect", str(tmp_path / "shot.png"), "--camera", str(tmp_path / "cam.toml"),
                 "--size", "50"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("id 4: position [20.0, -10.0, 450.0] mm")


def test_cli_calibrate_writes_a_camera_file(tmp_path, capsys):
    import cv2
    import numpy as np
    from scipy.spatial.transform import Rotation

    from labkit.vision import Camera, VirtualCamera

    truth = Camera.pinhole(800.0, (800, 600), distortion=[-0.05, 0.0, 0.0, 0.0, 0.0])
    cam = VirtualCamera(truth, noise=1.0, seed=4)
    rng = np.random.default_rng(8)
    paths = []
    for k in range(7):
        T = np.eye(4)
        T[:3, :3] = (Rotation.from_rotvec([np.pi, 0, 0]) * Rotation.from_rotvec(rng.uniform(-0.5, 0.5, 2).tolist() + [0])).as_matrix()
        T[:3, 3] = [rng.uniform(-0.03, 0.03), rng.uniform(-0.03, 0.03), 0.45]
        paths.append(str(tmp_path / f"shot{k}.png"))
        cv2.imwrite(paths[-1], cam.render_board(CharucoBoard(7, 5, 0.03, 0.022), T))
    out = tmp_path / "webcam.camera.toml"
    assert main(["vision", "calibrate", *paths, "-o", str(out)]) == 0
    assert "RMS reprojection error" in capsys.readouterr().out
    fx = Camera.load(out).focal[0]
    assert abs(fx / 800.0 - 1) < 0.01


def test_the_marker_is_drawn_at_true_size_from_the_unresampled_texture(tmp_path):
    import zlib

    from labkit.vision import marker_sheet, marker_texture

    data = marker_sheet(tmp_path / "m.pdf", [7], 0.04).read_bytes()
    placed = []
    for stream in re.findall(rb"stream\r?\n(.*?)\r?\nendstream", data, re.S):
        try:
            text = zlib.decompress(stream)
        except zlib.error:
            continue
        placed += re.findall(rb"cm ([\d.]+) 0 0\s+-?([\d.]+) 0 [\d.]+ cm /I\d+ Do", text)
    assert len(placed) == 1
    width_mm, height_mm = (float(v) / 72 * 25.4 for v in placed[0])
    # 40 mm black square + 2 white bits each side of 8 bits: 60 mm
    assert abs(width_mm - 60.0) < 0.01 and abs(height_mm - 60.0) < 0.01
    side = marker_texture("tag36h11", 7).shape[1]
    assert re.search(rb"/Width %d\b" % side, data), "embedded as drawn, not resampled to the figure's dpi"
