"""Rendering planar textures (markers, boards) into a camera image, with distortion.

Every pixel is traced back through the camera's distortion model to its ray
(the undistorted map is computed once per camera), the ray meets the plane,
and the plane's texture is sampled there. The texture is low-pass filtered to
the footprint of a pixel first (an area average, so edges are anti-aliased
and sub-pixel corners stay unbiased). Lighting, optical blur and sensor noise
are applied to the whole frame by :func:`expose`.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from labkit.exceptions import ShapeError, needs_extra

__all__ = ["Plane", "RayMap", "draw_planes", "expose", "GRAZING_COS"]

#: sheets seen more obliquely than arccos(GRAZING_COS) = 80 deg are not drawn (an edge, hidden by its mount)
GRAZING_COS = 0.17


@dataclasses.dataclass(frozen=True, eq=False)
class Plane:
    """A flat printed sheet in the scene.

    Attributes
    ----------
    camera_from_plane : ndarray, shape (4, 4)
        Pose of the sheet in the camera frame [m]; the sheet lies in its x-y plane,
        centred on its origin, its printed side facing +z.
    texture : ndarray, shape (rows, cols)
        Reflectance 0 (black) .. 1 (white); row 0 is the sheet's +y edge.
    extent : tuple of float
        ``(width, height)`` of the sheet [m] (along x and y).
    """

    camera_from_plane: np.ndarray
    texture: np.ndarray
    extent: tuple


class RayMap:
    """The undistorted ray ``(x, y, 1)`` of every pixel of a camera (computed once).

    Parameters
    ----------
    camera : Camera
        A camera with an ``image_size``.
    """

    def __init__(self, camera):
        if camera.image_size is None:
            raise ShapeError("expected a camera with image_size (width, height), got None")
        self.camera = camera
        w, h = camera.image_size
        u, v = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
        xy = camera.undistort_points(np.stack([u, v], axis=-1))
        self.x = xy[..., 0].astype(np.float64)
        self.y = xy[..., 1].astype(np.float64)


def _blurred(texture, sigma):
    with needs_extra("vision"):
        import cv2

    if sigma < 0.3:
        return texture
    k = int(2 * round(3 * sigma) + 1)
    return cv2.GaussianBlur(texture, (k, k), sigma, borderType=cv2.BORDER_REPLICATE)


def draw_planes(canvas, raymap, planes):
    """Paint planes into a reflectance canvas (far ones first; back faces are not drawn).

    Parameters
    ----------
    canvas : ndarray, shape (height, width), float32
        Reflectance image, modified in place.
    raymap : RayMap
        The camera's pixel rays.
    planes : sequence of Plane

    Returns
    -------
    ndarray, shape (height, width)
        ``canvas``.
    """
    with needs_extra("vision"):
        import cv2

    cam = raymap.camera
    h, w = canvas.shape
    order = sorted(planes, key=lambda p: -float(np.linalg.norm(np.asarray(p.camera_from_plane)[:3, 3])))
    for plane in order:
        T = np.asarray(plane.camera_from_plane, dtype=float)
        R, t = T[:3, :3], T[:3, 3]
        n = R[:, 2]
        if float(n @ t) >= -GRAZING_COS * float(np.linalg.norm(t)):
            continue  # the camera sees the back of the sheet, or its edge (more than 80 deg off its normal)
        sx, sy = plane.extent
        corners = np.array([[-sx, sy, 0], [sx, sy, 0], [sx, -sy, 0], [-sx, -sy, 0]]) / 2
        cam_pts = corners @ R.T + t
        if np.any(cam_pts[:, 2] <= 1e-3):
            continue
        uv = cam.project(cam_pts)
        u0, v0 = np.floor(uv.min(axis=0)).astype(int) - 2
        u1, v1 = np.ceil(uv.max(axis=0)).astype(int) + 3
        u0, v0, u1, v1 = max(u0, 0), max(v0, 0), min(u1, w), min(v1, h)
        if u1 <= u0 or v1 <= v0:
            continue
        x = raymap.x[v0:v1, u0:u1]
        y = raymap.y[v0:v1, u0:u1]
        denom = n[0] * x + n[1] * y + n[2]
        with np.errstate(divide="ignore", invalid="ignore"):
            lam = float(n @ t) / denom
        px, py, pz = lam * x - t[0], lam * y - t[1], lam - t[2]
        lx = R[0, 0] * px + R[1, 0] * py + R[2, 0] * pz
        ly = R[0, 1] * px + R[1, 1] * py + R[2, 1] * pz
        tex = np.asarray(plane.texture, dtype=np.float32)
        rows, cols = tex.shape
        col = ((lx / sx + 0.5) * cols - 0.5).astype(np.float32)
        row = ((0.5 - ly / sy) * rows - 0.5).astype(np.float32)
        bad = ~(lam > 0)
        col[bad] = -10.0
        row[bad] = -10.0
        # texture pixels per image pixel at the middle of the sheet: the footprint to average over
        cv_, cu_ = row.shape[0] // 2, row.shape[1] // 2
        cu_ = min(max(cu_, 1), row.shape[1] - 2)
        cv_ = min(max(cv_, 1), row.shape[0] - 2)
        J = np.array([[col[cv_, cu_ + 1] - col[cv_, cu_ - 1], col[cv_ + 1, cu_] - col[cv_ - 1, cu_]],
                      [row[cv_, cu_ + 1] - row[cv_, cu_ - 1], row[cv_ + 1, cu_] - row[cv_ - 1, cu_]]]) / 2
        scale = float(np.sqrt(abs(np.linalg.det(J)))) if np.all(np.isfinite(J)) else 1.0
        sampled = cv2.remap(_blurred(tex, 0.5 * scale), col, row, cv2.INTER_LINEAR,
                            borderMode=cv2.BORDER_CONSTANT, borderValue=0.0)
        alpha = cv2.remap(np.ones_like(tex), col, row, cv2.INTER_LINEAR,
                          borderMode=cv2.BORDER_CONSTANT, borderValue=0.0)
        roi = canvas[v0:v1, u0:u1]
        roi[...] = roi * (1.0 - alpha) + sampled * alpha
    return canvas


def expose(canvas, *, gain=0.85, offset=0.05, gradient=(0.0, 0.0), blur=0.0, noise=0.0, rng=None):
    """Turn a reflectance canvas into an 8-bit grey image: light, lens blur, sensor noise.

    Parameters
    ----------
    canvas : ndarray, shape (height, width)
        Reflectance 0..1.
    gain : float
        Light level: grey value of white paper as a fraction of full scale [1].
    offset : float
        Black level (ambient light, sensor offset) [1 of full scale].
    gradient : tuple of float
        Relative change of the light across the image, left to right and top to bottom [1].
    blur : float
        Standard deviation of the Gaussian lens blur [px].
    noise : float
        Standard deviation of the sensor noise [grey levels of 255].
    rng : numpy.random.Generator, optional
        Noise generator (default a fresh unseeded one).

    Returns
    -------
    ndarray, shape (height, width), uint8
    """
    with needs_extra("vision"):
        import cv2

    h, w = canvas.shape
    gx, gy = gradient
    light = _light(h, w, float(gx), float(gy)) * np.float32(gain * 255.0)
    img = cv2.multiply(np.ascontiguousarray(canvas, dtype=np.float32), light)
    img += np.float32(offset * 255.0)
    img = _blurred(img, blur)
    if noise > 0:
        rng = np.random.default_rng() if rng is None else rng
        img += np.float32(noise) * rng.standard_normal(img.shape, dtype=np.float32)
    img += np.float32(0.5)
    np.clip(img, 0.0, 255.0, out=img)
    return img.astype(np.uint8)


@functools.lru_cache(maxsize=8)
def _light(h, w, gx, gy):
    light = 1.0 + gx * (np.arange(w, dtype=np.float32)[None, :] / w - 0.5) + gy * (
        np.arange(h, dtype=np.float32)[:, None] / h - 0.5)
    light = np.ascontiguousarray(np.broadcast_to(light, (h, w)), dtype=np.float32)
    light.flags.writeable = False
    return light
