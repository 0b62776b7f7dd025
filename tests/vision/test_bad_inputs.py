"""Issue 41: every bad vision input is a LabkitError saying what was expected (the probed cases, then a sweep)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from labkit.exceptions import LabkitError, ShapeError, VisionError
from labkit.vision import Camera, Checkerboard, calibrate_camera, detect_markers

K = [[500.0, 0.0, 320.0], [0.0, 500.0, 240.0], [0.0, 0.0, 1.0]]
CAMERA_FILE = 'format = "labkit-camera/1"\nmatrix = [[500, 0, 320], [0, 500, 240], [0, 0, 1]]\n'


@pytest.mark.parametrize("data, match", [
    (bytes(range(256)), "UTF-8 TOML camera file"),
    (CAMERA_FILE.encode("utf-16"), "UTF-8 TOML camera file"),
    (CAMERA_FILE.encode() + b"image_size = 'big'\n", "image_size as two whole numbers"),
    (CAMERA_FILE.encode() + b"image_size = [640.5, 480]\n", "image_size as two whole numbers"),
    (CAMERA_FILE.encode() + b"distortion = [1e300, 0, 0, 0, 0]\n", "within"),
    (CAMERA_FILE.encode().replace(b"[0, 500, 240]", b"[0, 500]"), "camera matrix as numbers"),
    (CAMERA_FILE.encode() + b"name = 3\n", "name as text"),
])
def test_bad_camera_files_are_refused(tmp_path, data, match):
    path = tmp_path / "camera.toml"
    path.write_bytes(data)
    with pytest.raises(LabkitError, match=match):
        Camera.load(path)


def test_a_camera_file_needs_a_path():
    with pytest.raises(VisionError, match=r"expected the camera file as a path \(str or os.PathLike\), got None"):
        Camera.load(None)


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(matrix=[[1, 0], [0, 1, 0], [0, 0, 1]]), ShapeError, "camera matrix as numbers"),
    (dict(matrix=[["a", "b", "c"]] * 3), ShapeError, "camera matrix as numbers"),
    (dict(matrix=[[500, 30, 320], [0, 500, 240], [0, 0, 1]]), VisionError, "no skew"),
    (dict(matrix=K, image_size="big"), VisionError, "got 'big'"),
    (dict(matrix=K, image_size=(640.5, 480)), VisionError, r"got \(640.5, 480\)"),
    (dict(matrix=K, image_size=(640, 480, 3)), VisionError, "two whole numbers"),
    (dict(matrix=K, image_size=(True, 480)), VisionError, "two whole numbers"),
    (dict(matrix=K, distortion=[1e300, 0, 0, 0, 0]), VisionError, "within"),
    (dict(matrix=K, distortion="abc"), ShapeError, "distortion coefficients as numbers"),
])
def test_bad_camera_arguments_are_refused(kwargs, error, match):
    with pytest.raises(error, match=match):
        Camera(**kwargs)


def test_whole_float_image_sizes_are_taken():
    assert Camera(K, image_size=(640.0, np.int64(480))).image_size == (640, 480)
    assert Camera.pinhole(500.0, (640, 480)).image_size == (640, 480)


@pytest.mark.parametrize("image, match", [
    (np.zeros((0, 0), np.uint8), r"32 to 32767 px a side, got shape \(0, 0\)"),
    (np.zeros((1, 100_000_000), np.uint8), "px a side"),
    (np.array([[object()] * 40] * 40), "integers or floats, got an array of dtype object"),
    (np.full((40, 40), np.nan), "finite"),
    ("abc", "integers or floats"),
    (np.zeros((40, 40, 2)), "grey"),
])
def test_bad_images_are_refused(image, match):
    with pytest.raises(ShapeError, match=match):
        detect_markers(image, "aruco4x4_50")
    with pytest.raises(ShapeError, match=match):
        Checkerboard(7, 5, 0.02).detect(image)


def test_calibration_refuses_bad_images_and_sizes():
    with pytest.raises(ShapeError, match="px a side"):
        calibrate_camera([np.zeros((0, 0), np.uint8)] * 5, Checkerboard(7, 5, 0.02))
    with pytest.raises(VisionError, match="image_size"):
        calibrate_camera([np.zeros((40, 40), np.uint8)] * 5, Checkerboard(7, 5, 0.02), image_size="big")
    with pytest.raises(VisionError, match="sequence of images"):
        calibrate_camera(3, Checkerboard(7, 5, 0.02))


# -- the sweep: anything a student or a file can hand over -------------------------------------------------

_numbers = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**6, 10**6), st.booleans())
_things = st.one_of(
    _numbers, st.none(), st.text(max_size=5), st.binary(max_size=5),
    st.lists(_numbers, max_size=5), st.lists(st.lists(_numbers, max_size=4), max_size=4),
    st.tuples(_numbers, _numbers), st.dictionaries(st.text(max_size=3), _numbers, max_size=2),
)
_shapes = st.lists(st.integers(0, 48), min_size=0, max_size=4).map(tuple)
_dtypes = st.sampled_from(["uint8", "uint16", "int64", "float32", "float64", "bool", "object", "complex128"])


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(matrix=st.one_of(_things, st.just(K)), distortion=st.one_of(_things, st.just([0.1, 0, 0, 0])),
       image_size=st.one_of(_things, st.just((640, 480))), name=st.one_of(st.text(max_size=3), _numbers))
def test_any_camera_arguments_give_a_camera_or_a_labkit_error(matrix, distortion, image_size, name):
    try:
        camera = Camera(matrix, distortion, image_size, name)
    except LabkitError as exc:
        assert str(exc).startswith("expected"), str(exc)
        return
    assert camera.matrix.shape == (3, 3) and np.isfinite(camera.distortion).all()
    assert np.abs(camera.distortion).max(initial=0) <= 1e4 and camera.matrix[0, 1] == 0
    assert camera.image_size is None or all(type(v) is int and v >= 32 for v in camera.image_size)


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(shape=_shapes, dtype=_dtypes, fill=st.one_of(st.floats(), st.integers(-300, 300)))
def test_any_array_as_an_image_gives_detections_or_a_labkit_error(shape, dtype, fill):
    try:
        image = np.full(shape, fill, dtype=dtype) if dtype != "object" else np.full(shape, fill, dtype=object)
    except (OverflowError, ValueError, TypeError):
        return  # numpy itself will not hold that fill in that dtype: nothing reaches labkit
    for call in (lambda: detect_markers(image, "aruco4x4_50"), lambda: Checkerboard(7, 5, 0.02).detect(image)):
        try:
            call()
        except LabkitError as exc:
            assert "expected" in str(exc), str(exc)


@settings(max_examples=60, deadline=None)
@given(data=st.binary(max_size=200) | st.text(max_size=200).map(lambda s: s.encode("utf-16")))
def test_any_bytes_as_a_camera_file_give_a_camera_or_a_labkit_error(tmp_path_factory, data):
    path = tmp_path_factory.mktemp("cam") / "camera.toml"
    path.write_bytes(CAMERA_FILE.encode() + data if data[:1] == b"\n" else data)
    try:
        Camera.load(path)
    except LabkitError as exc:
        assert "expected" in str(exc), str(exc)


def test_views_that_fit_no_rigid_setup_are_a_vision_error():
    from scipy.spatial.transform import Rotation

    from labkit.vision import hand_eye

    def unrelated(seed):
        rng = np.random.default_rng(seed)
        T = np.tile(np.eye(4), (6, 1, 1))
        T[:, :3, :3] = Rotation.from_rotvec(rng.uniform(-0.6, 0.6, (6, 3))).as_matrix()
        T[:, :3, 3] = rng.uniform(-0.2, 0.2, (6, 3))
        return T

    poses = unrelated(1), unrelated(2)
    with pytest.raises(VisionError, match="expected views of one rigid eye_to_hand setup"):
        hand_eye(poses[0], poses[1], start="park", min_spread=0.0)  # unrelated poses: OpenCV's start is no rotation


def test_a_charuco_texture_too_coarse_for_its_markers_names_a_count_that_works():
    from labkit.exceptions import OptionError
    from labkit.vision import CharucoBoard

    board = CharucoBoard(5, 4, 0.03, 0.022)
    with pytest.raises(OptionError, match=r"got 8; try (\d+)") as info:
        board.texture(8)
    works = int(info.value.args[0].rsplit("try ", 1)[1])
    assert board.texture(works).shape == (4 * works + 2 * round(0.5 * works), 5 * works + 2 * round(0.5 * works))
