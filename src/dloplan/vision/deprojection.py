"""From pixels to 3D points: pinhole deprojection with depth or onto a known plane (thesis 7.1.2).

A pixel (u, v) is first undistorted to normalized coordinates (x_n, y_n) = (x/z, y/z) with the
intrinsics (``cv2.undistortPoints``); its 3D point in the camera frame is then z (x_n, y_n, 1)
for a depth z along the optical axis (a depth image, as a RealSense aligned to the colour image
gives it), or the intersection of the pixel's ray with a known plane, e.g. the table a flat
cable lies on. Eq. 7.3 then brings camera-frame points to the robot frame.
"""

from __future__ import annotations

import math

import numpy as np

from .camera import CameraIntrinsics, normalize_pixels
from .transforms import check_pose


def _pixels(pixels) -> np.ndarray:
    arr = np.asarray(pixels, dtype=float)
    if arr.ndim != 2 or arr.shape[1] != 2 or len(arr) == 0:
        raise ValueError(f"pixels: expected shape (k, 2) with k >= 1, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("pixels: non-finite pixel coordinates")
    return arr


def deproject_depth(pixels, depths, intrinsics: CameraIntrinsics) -> np.ndarray:
    """Camera-frame points of pixels at known depths: p^c = z (x_n, y_n, 1).

    Parameters
    ----------
    pixels : array_like
        (k, 2) pixel coordinates (u, v) [px].
    depths : array_like
        (k,) depth z along the optical axis [m], > 0.
    intrinsics : CameraIntrinsics

    Returns
    -------
    numpy.ndarray
        (k, 3) points in the camera frame [m].
    """
    pix = _pixels(pixels)
    z = np.asarray(depths, dtype=float)
    if z.shape != (len(pix),):
        raise ValueError(f"depths: expected shape ({len(pix)},), got {z.shape}")
    bad = ~(np.isfinite(z) & (z > 0))
    if np.any(bad):
        k = int(np.argmax(bad))
        raise ValueError(f"depths: depth {z[k]!r} at pixel {pix[k].tolist()} is not > 0 [m]")
    normalized = normalize_pixels(pix, intrinsics)
    return z[:, None] * np.column_stack([normalized, np.ones(len(pix))])


def depth_at_pixels(depth_image, pixels, depth_scale: float = 0.001, window: int = 2) -> np.ndarray:
    """Depth [m] at pixels: the median of the valid depths in a (2w+1)^2 window.

    Parameters
    ----------
    depth_image : array_like
        (height, width) depth image aligned to the colour image, in units of ``depth_scale``
        (a RealSense z16 image: uint16 millimetres, ``depth_scale=0.001``); 0 = no depth.
    pixels : array_like
        (k, 2) pixel coordinates (u, v) [px], rounded to the nearest pixel.
    depth_scale : float
        Metres per depth unit.
    window : int
        Half-width of the window [px]; the median skips the holes a depth camera leaves.

    Returns
    -------
    numpy.ndarray
        (k,) depths [m]; NaN where the whole window has no depth.
    """
    depth = np.asarray(depth_image)
    if depth.ndim != 2:
        raise ValueError(f"depth_image: expected a (height, width) image, got shape {depth.shape}")
    if not (math.isfinite(depth_scale) and depth_scale > 0):
        raise ValueError(f"depth_scale: got {depth_scale!r}, expected metres per unit > 0")
    if int(window) != window or window < 0:
        raise ValueError(f"window: got {window!r}, expected an integer >= 0")
    pix = np.rint(_pixels(pixels)).astype(int)
    height, width = depth.shape
    outside = (pix[:, 0] < 0) | (pix[:, 0] >= width) | (pix[:, 1] < 0) | (pix[:, 1] >= height)
    if np.any(outside):
        k = int(np.argmax(outside))
        raise ValueError(f"pixels: pixel {pix[k].tolist()} is outside the {width}x{height} image")
    offsets = np.arange(-window, window + 1)
    rows = np.clip(pix[:, 1, None, None] + offsets[None, :, None], 0, height - 1)
    cols = np.clip(pix[:, 0, None, None] + offsets[None, None, :], 0, width - 1)
    values = depth[rows, cols].reshape(len(pix), -1).astype(float) * depth_scale
    values[~(np.isfinite(values) & (values > 0))] = np.nan
    out = np.full(len(pix), np.nan)
    valid = ~np.all(np.isnan(values), axis=1)
    out[valid] = np.nanmedian(values[valid], axis=1)
    return out


def deproject_to_plane(pixels, intrinsics: CameraIntrinsics, camera_to_robot,
                       height: float) -> np.ndarray:
    """Robot-frame points where the pixels' rays meet the horizontal plane z = height.

    For a cable lying flat on a table at z = z_table, its centreline is at
    ``height = z_table + diameter / 2``.

    Parameters
    ----------
    pixels : array_like
        (k, 2) pixel coordinates (u, v) [px].
    intrinsics : CameraIntrinsics
    camera_to_robot : array_like
        (4, 4) extrinsic calibration A_c^r (eq. 7.2).
    height : float
        Plane height in the robot frame [m].

    Returns
    -------
    numpy.ndarray
        (k, 3) points in the robot frame [m].
    """
    pix = _pixels(pixels)
    transform = check_pose(camera_to_robot, "camera_to_robot")
    if not math.isfinite(height):
        raise ValueError(f"height: got {height!r}, expected a finite plane height [m]")
    normalized = normalize_pixels(pix, intrinsics)
    rays = np.column_stack([normalized, np.ones(len(pix))]) @ transform[:3, :3].T
    origin = transform[:3, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = (height - origin[2]) / rays[:, 2]
    bad = ~(np.isfinite(scale) & (scale > 0))
    if np.any(bad):
        k = int(np.argmax(bad))
        raise ValueError(
            f"height: the ray of pixel {pix[k].tolist()} does not reach the plane z = {height} m "
            f"(camera at z = {origin[2]:.4g} m)"
        )
    return origin + scale[:, None] * rays
