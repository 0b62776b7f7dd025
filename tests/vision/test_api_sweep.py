"""The bad-input sweep (tests/api_sweep.py) over labkit.vision's public functions and constructors (issue 41).

Each working call below has one argument at a time replaced by the bad values of its kind (NaN and inf in
arrays, a scalar, one element too many, ragged lists, a string, None, a dict, an empty array, True, zero and
negative sizes and counts, unknown option strings, a non-path). Every variant must be a LabkitError saying what
was expected, or be listed in :data:`ACCEPTED` with the reason its result is right; no other exception, no NaN
out of finite input, no hang.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from labkit import vision
from tests.api_sweep import call, outcome, sweep

K = [[500.0, 0.0, 320.0], [0.0, 500.0, 240.0], [0.0, 0.0, 1.0]]
CAMERA = vision.Camera(K, image_size=(640, 480))
IMAGE = np.zeros((64, 64), np.uint8)
FACING = np.array([[1.0, 0, 0, 0.01], [0, -1, 0, 0], [0, 0, -1, 0.5], [0, 0, 0, 1]])  # a marker 0.5 m ahead, facing us

ZERO_SEED = "0 is a seed like any other, None fresh entropy (numpy's default_rng)"
ZERO_TOLERATED = "zero is a valid value here (no margin, no blur, no noise, black, the first id)"
EMPTY_SCENE = "an empty mapping: no markers, an image of the background"


def _poses(n, seed):
    rng = np.random.default_rng(seed)
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, :3, :3] = Rotation.from_rotvec(rng.uniform(-0.6, 0.6, (n, 3))).as_matrix()
    T[:, :3, 3] = rng.uniform(-0.2, 0.2, (n, 3))
    return T


def sweep_calls():
    """Every working call of the vision sweep."""
    board, charuco = vision.Checkerboard(7, 5, 0.015), vision.CharucoBoard(5, 4, 0.03, 0.022)
    virtual = vision.VirtualCamera(CAMERA, noise=0.0)
    tools = _poses(6, 1)
    camera_pose, marker_pose = _poses(2, 2)  # base_from_camera, tool_from_marker: views of one rigid eye-to-hand rig
    seen = np.linalg.inv(camera_pose) @ tools @ marker_pose
    return [
        call("Camera", vision.Camera, K, [0.1, 0, 0, 0], (640, 480), "cam",
             kinds="matrix:array distortion:array image_size:array name:text"),
        call("Camera.pinhole", vision.Camera.pinhole, 500.0, (640, 480), kinds="focal:positive image_size:array"),
        call("Camera.project", CAMERA.project, [[0.0, 0.0, 1.0]], np.eye(4),
             kinds="points:array camera_from_points:array"),
        call("Camera.undistort_points", CAMERA.undistort_points, [[320.0, 240.0]], kinds="pixels:array"),
        call("Camera.save", CAMERA.save, "x.camera.toml", kinds="path:text"),
        call("Camera.load", vision.Camera.load, "missing.camera.toml", kinds="path:text"),
        call("family_info", vision.family_info, "tag36h11", kinds="family:option"),
        call("marker_texture", vision.marker_texture, "tag36h11", 3, pixels_per_bit=4, quiet_zone=2,
             kinds="family:option marker_id:count pixels_per_bit:count quiet_zone:count"),
        call("detect_markers", vision.detect_markers, IMAGE, "tag36h11", CAMERA,
             kinds="image:array family:option camera:object"),
        call("marker_corners", vision.marker_corners, 0.04, kinds="size:positive"),
        call("Checkerboard", vision.Checkerboard, 7, 5, 0.02, 1.0,
             kinds="columns:count rows:count square:positive margin:positive"),
        call("CharucoBoard", vision.CharucoBoard, 5, 4, 0.03, 0.022, "aruco5x5_100", 0.5,
             kinds="columns:count rows:count square:positive marker:positive family:option margin:positive"),
        call("Checkerboard.texture", board.texture, 8, kinds="pixels_per_square:count"),
        call("CharucoBoard.texture", charuco.texture, 12, kinds="pixels_per_square:count"),
        call("Checkerboard.detect", board.detect, IMAGE, kinds="image:array"),
        call("look_at", vision.look_at, [1.0, 0.0, 1.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0],
             kinds="eye:array target:array up:array"),
        call("face_marker", vision.face_marker, [0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.1, 0.2, 0.0],
             kinds="normal:array along:array centre:array"),
        call("rotation_spread", vision.rotation_spread, tools, kinds="base_from_tool:array"),
        call("hand_eye", vision.hand_eye, tools, seen, setup="eye_to_hand", start="park", min_spread=0.0,
             leave_one_out=False, kinds="base_from_tool:array camera_from_marker:array setup:option start:option "
                                       "min_spread:number"),
        call("marker_sheet", vision.marker_sheet, "m.pdf", [1, 2], 0.04, "tag36h11", paper="a4", gap=0.01,
             kinds="path:text ids:array size:positive family:option paper:option gap:number"),
        call("board_sheet", vision.board_sheet, "b.pdf", board, paper="a4", kinds="path:text board:object paper:option"),
        call("VirtualCamera", vision.VirtualCamera, CAMERA, size=0.04, family="tag36h11", noise=1.0, blur=0.5,
             gain=0.8, offset=0.05, gradient=(0.2, 0.1), background=0.45, seed=3,
             kinds="camera:object size:positive family:option noise:positive blur:positive gain:positive "
                   "offset:positive gradient:array background:positive seed:count"),
        call("VirtualCamera.render_markers", virtual.render_markers, {3: FACING}, 0.04, "tag36h11",
             kinds="poses:object size:positive family:option"),
        call("VirtualCamera.render_board", virtual.render_board, board, FACING, 8,
             kinds="board:object camera_from_board:array pixels_per_square:count"),
        call("FolderSource", vision.FolderSource, ".", kinds="folder:text"),
        call("CameraRig.around", vision.CameraRig.around, "openmanipulator_x", camera=CAMERA, marker_size=0.04,
             distance_factor=1.25, seed=0,
             kinds="robot:robot camera:object marker_size:positive distance_factor:positive seed:count"),
    ]


#: (call, argument) -> (bad-value labels that return a right result, why)
ACCEPTED = {
    ("Camera", "distortion"): ({"empty", "longer"}, "no coefficients (no distortion), or OpenCV's 5-coefficient model"),
    ("detect_markers", "image"): ({"longer"}, "a wider image (64 x 65 px)"),
    ("Checkerboard.detect", "image"): ({"longer"}, "a wider image (64 x 65 px)"),
    ("marker_texture", "marker_id"): ({"zero"}, ZERO_TOLERATED),
    ("marker_texture", "quiet_zone"): ({"zero"}, ZERO_TOLERATED),
    ("Checkerboard", "margin"): ({"zero"}, ZERO_TOLERATED),
    ("CharucoBoard", "margin"): ({"zero"}, ZERO_TOLERATED),
    ("VirtualCamera", "seed"): ({"zero", "none"}, ZERO_SEED),
    ("VirtualCamera", "noise"): ({"zero"}, ZERO_TOLERATED),
    ("VirtualCamera", "blur"): ({"zero"}, ZERO_TOLERATED),
    ("VirtualCamera", "offset"): ({"zero"}, ZERO_TOLERATED),
    ("VirtualCamera", "gain"): ({"zero"}, ZERO_TOLERATED),
    ("VirtualCamera", "background"): ({"zero"}, ZERO_TOLERATED),
    ("VirtualCamera", "size"): ({"dict"}, "sizes by id: an empty mapping for a scene without markers"),
    ("VirtualCamera.render_markers", "poses"): ({"dict"}, EMPTY_SCENE),
    ("CameraRig.around", "seed"): ({"zero", "none"}, ZERO_SEED),
}
CALLS = sweep_calls()


@pytest.fixture(autouse=True)
def _in_a_temporary_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # the sheets and camera files are written here


@pytest.mark.parametrize("c", CALLS, ids=lambda c: c.name)
def test_the_working_call_of_the_vision_sweep_works(c):
    if c.name == "Camera.load":  # the one call whose working input is a file: write it first
        CAMERA.save("missing.camera.toml")
    assert outcome(c.func, c.args, c.kwargs) == "ok"


@pytest.mark.parametrize("c", CALLS, ids=lambda c: c.name)
def test_bad_vision_input_is_a_labkit_error_that_says_what_was_expected(c):
    failures, stale = sweep(c, ACCEPTED)
    assert not failures, "\n".join(failures)
    assert not stale, f"accepted but no longer returning (drop them from ACCEPTED): {stale}"


def test_every_accepted_case_names_a_call_of_the_vision_sweep():
    assert {name for name, _ in ACCEPTED} <= {c.name for c in CALLS}
