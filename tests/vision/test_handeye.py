"""Hand-eye calibration on synthetic views with known truth: accuracy, pairing by id, too-alike views."""

import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from labkit.exceptions import LabkitError
from labkit.vision import HandEyeWarning, hand_eye


def _T(rotvec, t):
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(rotvec).as_matrix()
    T[:3, 3] = t
    return T


BASE_FROM_CAMERA = _T([2.2, 0.3, -0.4], [0.45, 0.3, 0.5])
TOOL_FROM_MARKER = _T([0.1, -0.2, 0.3], [0.01, 0.02, 0.03])


def _views(n, spread, seed, noise_m=3e-4, noise_rad=3e-3):
    rng = np.random.default_rng(seed)
    tools, seen = {}, {}
    for k in range(n):
        A = _T(rng.uniform(-spread, spread, 3), rng.uniform(-0.15, 0.15, 3) + [0.25, 0.0, 0.2])
        B = np.linalg.inv(BASE_FROM_CAMERA) @ A @ TOOL_FROM_MARKER
        B = B @ _T(rng.normal(0, noise_rad, 3), rng.normal(0, noise_m, 3))
        tools[f"p{k}"], seen[f"p{k}"] = A, B
    return tools, seen


def _angle(R):
    return np.linalg.norm(Rotation.from_matrix(R).as_rotvec())


def test_eye_to_hand_from_varied_views_within_2mm_and_half_a_degree():
    tools, seen = _views(24, 0.8, seed=1)
    with warnings.catch_warnings():
        warnings.simplefilter("error", HandEyeWarning)
        r = hand_eye(tools, seen, setup="eye_to_hand")
    assert np.linalg.norm(r.camera_pose[:3, 3] - BASE_FROM_CAMERA[:3, 3]) <= 2e-3
    assert np.degrees(_angle(r.camera_pose[:3, :3].T @ BASE_FROM_CAMERA[:3, :3])) <= 0.5
    assert np.linalg.norm(r.marker_pose[:3, 3] - TOOL_FROM_MARKER[:3, 3]) <= 2e-3
    assert np.median(r.position_residual) < 2e-3 and np.all(r.loo_position >= 0)
    assert len(r.to_dataframe()) == 24


def test_eye_in_hand_is_the_same_problem_seen_from_the_gripper():
    rng = np.random.default_rng(4)
    tool_from_camera, base_from_marker = TOOL_FROM_MARKER, BASE_FROM_CAMERA
    tools, seen = {}, {}
    for k in range(20):
        A = _T(rng.uniform(-0.8, 0.8, 3), rng.uniform(-0.15, 0.15, 3))
        tools[k] = A
        seen[k] = np.linalg.inv(A @ tool_from_camera) @ base_from_marker
    r = hand_eye(tools, seen, setup="eye_in_hand", leave_one_out=False)
    np.testing.assert_allclose(r.camera_pose, tool_from_camera, atol=1e-6)


def test_a_missed_detection_drops_its_view_and_never_shifts_the_pairs():
    tools, seen = _views(22, 0.8, seed=2)
    del seen["p7"]
    r = hand_eye(tools, seen, leave_one_out=False)
    assert r.dropped == ["p7"] and "p7" not in r.pose_ids
    assert np.linalg.norm(r.camera_pose[:3, 3] - BASE_FROM_CAMERA[:3, 3]) <= 2e-3
    # the same detections as a plain list (shifted by the missing one) would be wrong: the fit shows it
    shifted = hand_eye(list(tools.values())[:21], list(seen.values()), leave_one_out=False)
    assert np.median(shifted.position_residual) > 10 * np.median(r.position_residual)


def test_too_alike_views_warn():
    tools, seen = _views(15, 0.1, seed=3)
    with pytest.warns(HandEyeWarning, match="too alike"):
        hand_eye(tools, seen, leave_one_out=False)


@pytest.mark.parametrize("setup", ["eye_to_hand", "eye_in_hand"])
def test_robot_world_start_gives_the_same_calibration(setup):
    tools, seen = _views(20, 0.8, seed=6, noise_m=0.0, noise_rad=0.0)
    if setup == "eye_in_hand":  # the same views read as a camera on the gripper looking at a fixed marker
        tools = {k: np.linalg.inv(T) for k, T in tools.items()}
    start = {m: hand_eye(tools, seen, setup=setup, start=m, leave_one_out=False) for m in ("park", "shah", "li")}
    for m in ("shah", "li"):
        np.testing.assert_allclose(start[m].camera_pose, start["park"].camera_pose, atol=1e-6)
    assert np.median(start["park"].position_residual) < 1e-6


def test_unknown_setup_and_method_are_rejected():
    tools, seen = _views(5, 0.8, seed=7)
    with pytest.raises(LabkitError, match="setup as one of"):
        hand_eye(tools, seen, setup="eye_on_hand")
    with pytest.raises(LabkitError, match="start as one of"):
        hand_eye(tools, seen, start="guess")
