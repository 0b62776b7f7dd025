"""Marker detection and pose on synthetic images with known truth."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from labkit.vision import (AmbiguousPoseError, Camera, MarkerNotFoundError, VirtualCamera, WrongMarkerError,
                           marker_corners, marker_poses)

CAM = Camera.pinhole(1000.0, (1280, 960), distortion=[-0.1, 0.05, 0, 0, 0])


def _pose(tilt, azimuth, spin, position):
    T = np.eye(4)
    T[:3, :3] = (Rotation.from_rotvec([np.pi, 0, 0]) * Rotation.from_rotvec(tilt * np.array([np.cos(azimuth), np.sin(azimuth), 0]))
                 * Rotation.from_rotvec([0, 0, spin])).as_matrix()
    T[:3, 3] = position
    return T


def test_a_4cm_tag_at_half_a_metre_within_a_millimetre():
    rng = np.random.default_rng(0)
    cam = VirtualCamera(CAM, noise=1.5, blur=0.7, seed=1)
    errors, inside = [], []
    for _ in range(20):
        T = _pose(rng.uniform(0.35, 0.8), rng.uniform(0, 2 * np.pi), rng.uniform(-np.pi, np.pi),
                  [rng.uniform(-0.15, 0.15), rng.uniform(-0.1, 0.1), 0.5])
        [d] = marker_poses(cam.render_markers({5: T}, size=0.04), CAM, 0.04)
        assert d.id == 5 and not d.ambiguous
        e = d.position - T[:3, 3]
        errors.append(np.linalg.norm(e))
        inside.append(np.all(np.abs(e) <= 3 * d.uncertainty))
    assert np.median(errors) <= 1e-3
    assert np.mean(inside) >= 0.9


def test_a_face_on_small_marker_is_ambiguous():
    cam = VirtualCamera(CAM, noise=2.0, blur=1.0, seed=2)
    T = _pose(0.02, 0.0, 0.3, [0.0, 0.0, 1.2])
    image = cam.render_markers({3: T}, size=0.03)
    with pytest.raises(AmbiguousPoseError, match="about equally"):
        marker_poses(image, CAM, 0.03)
    [d] = marker_poses(image, CAM, 0.03, on_ambiguous="keep")
    assert d.ambiguous and d.alternative_error < 3 * max(d.reprojection_error, 0.1)


def test_no_marker_and_wrong_id_are_clear_errors():
    cam = VirtualCamera(CAM, noise=1.0, seed=3)
    with pytest.raises(MarkerNotFoundError, match="found none"):
        marker_poses(cam.render_markers({}), CAM, 0.04)
    image = cam.render_markers({8: _pose(0.5, 0.2, 0.0, [0.0, 0.0, 0.5])}, size=0.04)
    with pytest.raises(WrongMarkerError, match=r"id\(s\) \[2\], found id\(s\) \[8\]"):
        marker_poses(image, CAM, 0.04, ids=2)
    assert [d.id for d in marker_poses(image, CAM, 0.04, ids=[2, 8])] == [8]


@pytest.mark.parametrize("tilt_deg", [72.0, 76.0])
def test_a_tag_seen_obliquely_keeps_its_edges_and_its_stated_uncertainty(tilt_deg):
    # a 100 mm tag at 1.3 m tilted about its diagonal, as a SCARA's side tag turns away from the camera: the quad
    # is a thin rhombus whose black border is a quarter of its side across; edge profiles as long as half a side
    # reached into the data bits and moved the corners by a pixel, the pose by 16 mm along the line of sight
    cam = VirtualCamera(CAM, noise=1.5, blur=0.6, seed=3)
    errors = []
    for azimuth in np.radians([40.0, 45.0, 135.0, 220.0]):
        T = _pose(np.radians(tilt_deg), azimuth, 0.0, [0.05, -0.03, 1.3])
        [d] = marker_poses(cam.render_markers({4: T}, size=0.1), CAM, 0.1, on_ambiguous="keep")
        corners = CAM.project((T[:3, :3] @ marker_corners(0.1).T).T + T[:3, 3])
        assert np.max(np.abs(d.corners - corners)) < 0.5, "corners within half a pixel"
        e = d.position - T[:3, 3]
        errors.append(np.max(np.abs(e) / (2 * d.uncertainty)))
    assert max(errors) <= 1.0, f"position errors up to {max(errors):.1f} times the stated uncertainty (k = 2)"
