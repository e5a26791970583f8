"""Register a cable's shape from a photograph: pixels -> robot-frame points -> n + 1 points.

The steps of thesis 7.1.2: the ordered centreline in pixels (:mod:`.centreline`), deprojected
to metres with the intrinsics and a depth (:mod:`.deprojection`), brought to the robot frame by
the extrinsic calibration (eq. 7.3), and resampled by arc length to the planner's n + 1 points
(Fig. 6.4). The deprojection comes before the resampling: equal steps in the image are not
equal steps on the cable under perspective.
"""

from __future__ import annotations

import math

import numpy as np

from ..geometry import resample_by_arc_length
from .calibration import ExtrinsicCalibration
from .camera import project_normalized
from .centreline import HsvRange, extract_centreline
from .deprojection import deproject_depth, deproject_to_plane, depth_at_pixels
from .shapes_io import RegisteredShape
from .transforms import invert_pose, transform_points


def _check(calibration, n_points, image) -> np.ndarray:
    """The arguments both registrations share, checked; the colour image of the calibration's
    size (:meth:`~dloplan.vision.camera.CameraIntrinsics.check_image`) returned."""
    if not isinstance(calibration, ExtrinsicCalibration):
        raise ValueError(
            f"calibration: expected ExtrinsicCalibration, got {type(calibration).__name__}")
    if isinstance(n_points, bool) or int(n_points) != n_points or n_points < 2:
        raise ValueError(f"n_points: got {n_points!r}, expected an integer >= 2 (n_links + 1)")
    return calibration.intrinsics.check_image(image)


def _start_pixel(start_near, calibration: ExtrinsicCalibration):
    """The pixel of a robot-frame point (for choosing which cable end comes first)."""
    if start_near is None:
        return None
    point = np.asarray(start_near, dtype=float)
    if point.shape != (3,) or not np.all(np.isfinite(point)):
        raise ValueError(f"start_near: got {start_near!r}, expected a point (x, y, z) [m]")
    in_camera = transform_points(invert_pose(calibration.camera_to_robot), point)
    if in_camera[2] <= 0:
        raise ValueError(f"start_near: {point.tolist()} is behind the camera")
    return project_normalized(in_camera[:2] / in_camera[2], calibration.intrinsics)[0]


def register_on_plane(image, calibration: ExtrinsicCalibration, colour: HsvRange,
                      n_points: int, height: float, *, start_near=None, label: str = "",
                      min_area: int = 50, smoothing: float = 2.0) -> RegisteredShape:
    """The shape of a cable lying flat on a plane z = height, from one colour image.

    Parameters
    ----------
    image : numpy.ndarray
        (height, width, 3) uint8 BGR image of the calibration's camera.
    calibration : ExtrinsicCalibration
        Intrinsics and camera_to_robot (eq. 7.2).
    colour : HsvRange
        The cable's colour.
    n_points : int
        Points of the result, n_links + 1.
    height : float
        Height of the cable's centreline in the robot frame [m]: the table's height plus
        half the cable's diameter.
    start_near : array_like, optional
        A robot-frame point [m] (e.g. the first clip): the shape starts at the cable end
        nearer to it in the image.
    label : str
        The result's label.
    min_area, smoothing
        See :func:`~dloplan.vision.centreline.extract_centreline`.

    Returns
    -------
    RegisteredShape
        (n_points, 3) points in the calibration's frame, equally spaced in arc length.
    """
    image = _check(calibration, n_points, image)
    if not (isinstance(height, int | float) and math.isfinite(height)):
        raise ValueError(f"height: got {height!r}, expected a plane height [m]")
    line = extract_centreline(image, colour, min_area=min_area, smoothing=smoothing,
                              start_near=_start_pixel(start_near, calibration))
    points = deproject_to_plane(line.pixels, calibration.intrinsics,
                                calibration.camera_to_robot, height)
    return RegisteredShape(resample_by_arc_length(points, int(n_points)), calibration.frame_id,
                           label)


def register_with_depth(image, depth_image, calibration: ExtrinsicCalibration,
                        colour: HsvRange, n_points: int, *, depth_scale: float = 0.001,
                        depth_offset: float = 0.0, start_near=None, label: str = "",
                        min_area: int = 50, smoothing: float = 2.0,
                        max_missing: float = 0.2) -> RegisteredShape:
    """The 3D shape of a cable from a colour image and an aligned depth image.

    The depth of each centreline pixel is the median of the valid depths around it; pixels
    without depth (holes of the depth camera) are dropped. A depth camera sees the cable's
    top surface: ``depth_offset`` (about the cable's radius [m]) moves the points down to the
    centreline along the optical axis.

    Parameters
    ----------
    depth_image : numpy.ndarray
        (height, width) depth aligned to ``image`` in units of ``depth_scale`` [m]; 0 = none.
        Both images of the intrinsics' size (ValueError naming the image, its size and the
        intrinsics').
    max_missing : float
        Largest fraction of centreline pixels allowed without depth.

    Other parameters are those of :func:`register_on_plane`.
    """
    image = _check(calibration, n_points, image)
    depth_image = calibration.intrinsics.check_image(depth_image, "depth_image")
    if not (isinstance(depth_offset, int | float) and math.isfinite(depth_offset)):
        raise ValueError(f"depth_offset: got {depth_offset!r}, expected a length [m]")
    line = extract_centreline(image, colour, min_area=min_area, smoothing=smoothing,
                              start_near=_start_pixel(start_near, calibration))
    depths = depth_at_pixels(depth_image, line.pixels, depth_scale)
    valid = np.isfinite(depths)
    missing = 1.0 - valid.mean()
    if missing > max_missing or valid.sum() < 2:
        raise ValueError(
            f"depth_image: {100 * missing:.0f} % of the cable's centreline has no depth "
            f"(allowed {100 * max_missing:.0f} %)"
        )
    in_camera = deproject_depth(line.pixels[valid], depths[valid] + depth_offset,
                                calibration.intrinsics)
    return RegisteredShape(resample_by_arc_length(calibration.to_robot(in_camera),
                                                  int(n_points)), calibration.frame_id, label)
