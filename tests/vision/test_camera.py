"""Camera model, its TOML file and calibration from synthetic board images with known truth."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from labkit.exceptions import LabkitError, ShapeError
from labkit.vision import Camera, CharucoBoard, Checkerboard, VirtualCamera, CalibrationImageError

TRUTH = Camera([[1010.0, 0, 645.0], [0, 1005.0, 478.0], [0, 0, 1]], [-0.12, 0.08, 0.0005, -0.0003, 0.0], (1280, 960))


def _views(board, n, seed):
    rng = np.random.default_rng(seed)
    cam = VirtualCamera(TRUTH, noise=1.0, blur=0.7, seed=seed)
    out = []
    for _ in range(n):
        R = (Rotation.from_rotvec([np.pi, 0, 0]) * Rotation.from_rotvec([rng.uniform(-0.6, 0.6), rng.uniform(-0.6, 0.6), 0])
             * Rotation.from_rotvec([0, 0, rng.uniform(-0.3, 0.3)]))
        T = np.eye(4)
        T[:3, :3] = R.as_matrix()
        T[:3, 3] = [rng.uniform(-0.12, 0.12), rng.uniform(-0.08, 0.08), rng.uniform(0.45, 0.7)]
        out.append(cam.render_board(board, T))
    return out


def test_save_load_round_trip(tmp_path):
    path = TRUTH.save(tmp_path / "webcam.camera.toml", rms_px=0.05)
    back = Camera.load(path)
    np.testing.assert_array_equal(back.matrix, TRUTH.matrix)
    np.testing.assert_array_equal(back.distortion, TRUTH.distortion)
    assert back.image_size == (1280, 960)
    assert "rms_px = 0.05" in path.read_text()


def test_bad_camera_and_file_are_rejected(tmp_path):
    with pytest.raises(ShapeError, match="3x3"):
        Camera(np.eye(2))
    with pytest.raises(LabkitError, match="fx, fy > 0"):
        Camera([[-1.0, 0, 0], [0, 1.0, 0], [0, 0, 1]])
    bad = tmp_path / "x.toml"
    bad.write_text('format = "other"\n')
    with pytest.raises(LabkitError, match="labkit-camera/1"):
        Camera.load(bad)


def test_project_and_undistort_are_inverse():
    pts = np.array([[0.1, -0.05, 0.6], [-0.2, 0.1, 0.5]])
    xy = TRUTH.undistort_points(TRUTH.project(pts))
    np.testing.assert_allclose(xy, pts[:, :2] / pts[:, 2:], atol=1e-9)


def test_charuco_calibration_recovers_the_intrinsics_and_flags_a_bad_image():
    board = CharucoBoard(8, 6, 0.035, 0.026)
    images = _views(board, 14, seed=3)
    # one image taken with another lens (focal 8 % longer): it must stand out
    other = Camera([[1090.0, 0, 645.0], [0, 1085.0, 478.0], [0, 0, 1]], TRUTH.distortion, TRUTH.image_size)
    T = np.eye(4)
    T[:3, :3] = (Rotation.from_rotvec([np.pi, 0, 0]) * Rotation.from_rotvec([0.4, 0.3, 0])).as_matrix()
    T[:3, 3] = [0.1, 0.05, 0.55]
    images.insert(5, VirtualCamera(other, noise=1.0, blur=0.7).render_board(board, T))
    cal = Camera.calibrate(images, board)
    assert cal.rms < 0.3
    K = cal.camera.matrix
    for got, want in [(K[0, 0], 1010.0), (K[1, 1], 1005.0), (K[0, 2], 645.0), (K[1, 2], 478.0)]:
        assert abs(got / want - 1) < 0.005
    assert cal.flagged[5] and not cal.used[5] and cal.flagged.sum() == 1
    assert cal.found.all() and len(cal.to_dataframe()) == 15


def test_checkerboard_calibration_meets_the_acceptance():
    board = Checkerboard(7, 5, 0.035)
    cal = Camera.calibrate(_views(board, 8, seed=5), board, flags=0)
    assert cal.rms < 0.3
    assert abs(cal.camera.focal[0] / 1010.0 - 1) < 0.005 and abs(cal.camera.focal[1] / 1005.0 - 1) < 0.005


def test_too_few_board_images_is_a_clear_error():
    board = CharucoBoard(8, 6, 0.035, 0.026)
    blank = [np.full((960, 1280), 128, np.uint8)] * 6
    with pytest.raises(CalibrationImageError, match="found it in 0 of 6"):
        Camera.calibrate(blank, board)
