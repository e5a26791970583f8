"""Extrinsic camera calibration from ArUco markers of known pose (thesis 7.1.1, eq. 7.2).

The thesis computes the camera's pose in the robot base frame from one marker whose pose in
the robot frame, A_m^r, is known and whose pose in the camera, A_m^c, is measured:

    A_c^r = A_m^r (A_m^c)^-1                                        (eq. 7.2)

:func:`calibrate_extrinsics` does exactly that for one marker. With several markers (a sheet
of markers spread over the work area) it starts from eq. 7.2 for the largest marker and then
solves one perspective-n-point problem for all their corners together (Levenberg-Marquardt on
the reprojection error), which is much better conditioned than a single small marker seen
from above: the tilt of a fronto-parallel square of 60 px is uncertain by tenths of a degree,
which moves the camera by millimetres.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ..bounds import WORKSPACE
from ..inputs import parse_json, read_text
from ..io.poses import canonical_quaternions, pose_from_dict, transform_dict
from ..output_files import atomic_write_text
from . import _deps
from .camera import CameraIntrinsics, project_normalized
from .markers import (
    MarkerLayout,
    MarkerNotFoundError,
    detect_markers,
    marker_corners,
    marker_to_camera,
)
from .transforms import check_pose, invert_pose, pose_matrix, transform_points

CALIBRATION_FORMAT = "dloplan-camera-calibration"


def camera_to_robot_from_marker(marker_to_robot, marker_to_camera) -> np.ndarray:
    """Eq. 7.2: A_c^r = A_m^r (A_m^c)^-1, (4, 4).

    Parameters
    ----------
    marker_to_robot : array_like
        (4, 4) marker pose in the robot frame, A_m^r [m].
    marker_to_camera : array_like
        (4, 4) marker pose in the camera frame, A_m^c [m].
    """
    return check_pose(marker_to_robot, "marker_to_robot") @ invert_pose(
        check_pose(marker_to_camera, "marker_to_camera"))


@dataclass(frozen=True)
class ExtrinsicCalibration:
    """The camera's pose in the robot frame and how well the markers support it.

    Attributes
    ----------
    camera_to_robot : numpy.ndarray
        (4, 4) A_c^r [m]: camera-frame coordinates -> robot-frame coordinates.
    intrinsics : CameraIntrinsics
    frame_id : str
        The robot frame's name (from the marker layout).
    marker_ids : tuple of int
        The layout's markers found and used.
    missing_ids : tuple of int
        The layout's markers not found in the image.
    reprojection_rms : float
        RMS distance between the detected and the reprojected marker corners [px].
    success : bool
        ``reprojection_rms`` within the tolerance the calibration was run with.
    message : str
    """

    camera_to_robot: np.ndarray
    intrinsics: CameraIntrinsics
    frame_id: str = "robot_base"
    marker_ids: tuple[int, ...] = ()
    missing_ids: tuple[int, ...] = ()
    reprojection_rms: float = 0.0
    success: bool = True
    message: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "camera_to_robot",
                           check_pose(self.camera_to_robot, "camera_to_robot"))
        if not isinstance(self.intrinsics, CameraIntrinsics):
            raise ValueError(
                f"intrinsics: expected CameraIntrinsics, got {type(self.intrinsics).__name__}")

    def to_robot(self, points_camera) -> np.ndarray:
        """Camera-frame points (..., 3) [m] -> robot-frame points (eq. 7.3)."""
        return transform_points(self.camera_to_robot, points_camera)


def calibrate_extrinsics(image, intrinsics: CameraIntrinsics, layout: MarkerLayout, *,
                         refine_edges: bool = True,
                         max_reprojection_rms: float = 0.5) -> ExtrinsicCalibration:
    """Camera pose in the robot frame from an image of markers of known pose (eq. 7.2).

    Parameters
    ----------
    image : numpy.ndarray
        (height, width[, 3]) uint8 image (BGR or grey) of the intrinsics' size.
    intrinsics : CameraIntrinsics
        The internal calibration.
    layout : MarkerLayout
        Marker dictionary, side length and poses in the robot frame (A_m^r).
    refine_edges : bool
        Locate corners from the markers' edges (see :func:`detect_markers`).
    max_reprojection_rms : float
        Above this RMS corner reprojection error [px] the result has ``success=False``.

    Raises
    ------
    MarkerNotFoundError
        (a ValueError) when none of the layout's markers is visible; the message lists the
        ids that were seen.
    """
    cv2 = _deps.cv2()
    if not isinstance(layout, MarkerLayout):
        raise ValueError(f"layout: expected a MarkerLayout, got {type(layout).__name__}")
    detections = detect_markers(image, intrinsics, layout.dictionary, refine_edges=refine_edges)
    used = [d for d in detections if d.marker_id in layout.poses]
    if not used:
        seen = [d.marker_id for d in detections]
        raise MarkerNotFoundError(
            f"image: none of the markers {sorted(layout.poses)} ({layout.dictionary}) is "
            f"visible; markers seen: {seen if seen else 'none'}"
        )
    # Eq. 7.2 from the marker that looks largest, then all corners together.
    largest = max(used, key=lambda d: abs(_area(d.normalized)))
    corners = marker_corners(layout.marker_length)
    camera_to_robot = camera_to_robot_from_marker(
        layout.poses[largest.marker_id], marker_to_camera(largest, layout.marker_length))
    object_points = np.concatenate(
        [transform_points(layout.poses[d.marker_id], corners) for d in used])
    image_points = np.concatenate([d.normalized for d in used])
    robot_to_camera = invert_pose(camera_to_robot)
    rvec = Rotation.from_matrix(robot_to_camera[:3, :3]).as_rotvec()
    tvec = robot_to_camera[:3, 3].copy()
    if len(used) > 1:
        rvec, tvec = cv2.solvePnPRefineLM(object_points, image_points, np.eye(3), np.zeros(5),
                                          rvec.reshape(3, 1), tvec.reshape(3, 1))
        robot_to_camera = pose_matrix(Rotation.from_rotvec(rvec.ravel()), tvec.ravel())
        camera_to_robot = invert_pose(robot_to_camera)
    in_camera = transform_points(robot_to_camera, object_points)
    projected = project_normalized(in_camera[:, :2] / in_camera[:, 2:], intrinsics)
    detected = np.concatenate([d.corners for d in used])
    rms = float(np.sqrt(np.mean(np.sum((projected - detected) ** 2, axis=1))))
    ids = tuple(d.marker_id for d in used)
    missing = tuple(sorted(set(layout.poses) - set(ids)))
    success = rms <= max_reprojection_rms
    message = (f"camera pose from {len(ids)} marker(s) {list(ids)}, corner reprojection RMS "
               f"{rms:.3f} px" + (f"; markers not seen: {list(missing)}" if missing else ""))
    if not success:
        message += (f"; above {max_reprojection_rms} px: check the marker poses, the marker "
                    "length and the intrinsics")
    return ExtrinsicCalibration(camera_to_robot, intrinsics, layout.frame_id, ids, missing, rms,
                                success, message)


def _area(quad: np.ndarray) -> float:
    x, y = quad[:, 0], quad[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def write_calibration(path, calibration: ExtrinsicCalibration) -> Path:
    """Write a calibration as JSON (format in docs/vision.md), atomically."""
    if not isinstance(calibration, ExtrinsicCalibration):
        raise ValueError(
            f"calibration: expected ExtrinsicCalibration, got {type(calibration).__name__}")
    rot = Rotation.from_matrix(calibration.camera_to_robot[:3, :3])
    data = {
        "format": CALIBRATION_FORMAT,
        "version": 1,
        "frame_id": calibration.frame_id,
        "camera_to_robot": transform_dict(calibration.camera_to_robot[:3, 3],
                                          canonical_quaternions(rot)[0]),
        "intrinsics": calibration.intrinsics.to_dict(),
        "marker_ids": list(calibration.marker_ids),
        "reprojection_rms_px": calibration.reprojection_rms,
        "success": calibration.success,
        "message": calibration.message,
    }
    return atomic_write_text(path, json.dumps(data, indent=2) + "\n")


def read_calibration(path) -> ExtrinsicCalibration:
    """Read a calibration JSON written by :func:`write_calibration` (or by hand)."""
    where = str(path)
    text = read_text(path, kind="camera calibration (JSON)")
    try:
        data = parse_json(text)
    except (ValueError, RecursionError) as exc:  # JSONDecodeError, a key twice
        raise ValueError(f"{where}: not a camera calibration (not valid JSON: {exc})") from None
    if not isinstance(data, dict) or data.get("format") != CALIBRATION_FORMAT:
        raise ValueError(f"{where}: expected a JSON object with format {CALIBRATION_FORMAT!r}")
    transform = data.get("camera_to_robot")
    if not isinstance(transform, dict):
        raise ValueError(f"{where}: missing 'camera_to_robot'")
    position, quat = pose_from_dict(
        {"position": transform.get("translation"), "orientation": transform.get("rotation")},
        f"{where}: camera_to_robot")
    distance = math.hypot(*position)
    if distance > WORKSPACE:
        raise ValueError(f"{where}: camera_to_robot.translation: the camera {distance:.4g} m "
                         f"from the robot, expected within {WORKSPACE:g} m (a length in wrong "
                         "units?)")
    intrinsics = CameraIntrinsics.from_dict(data.get("intrinsics"), f"{where}: intrinsics")
    fields = {"frame_id": "robot_base", "marker_ids": [], "reprojection_rms_px": 0.0,
              "success": True, "message": ""}
    fields.update({k: data[k] for k in fields if k in data})
    expected = {"frame_id": (str, "a frame name"), "message": (str, "a text"),
                "success": (bool, "true or false"),
                "reprojection_rms_px": (float, "a finite number >= 0 [px]"),
                "marker_ids": (list, "a list of marker ids (integers >= 0)")}
    for key, (kind, words) in expected.items():
        value = fields[key]
        ok = (isinstance(value, int | float) and not isinstance(value, bool)
              and math.isfinite(value) and value >= 0) if kind is float else isinstance(value, kind)
        if kind is list and ok:
            ok = all(isinstance(v, int) and not isinstance(v, bool) and v >= 0 for v in value)
        if not ok or (key == "frame_id" and not value):
            raise ValueError(f"{where}: {key}: got {value!r:.60}, expected {words}")
    return ExtrinsicCalibration(
        pose_matrix(Rotation.from_quat(quat), position), intrinsics, fields["frame_id"],
        tuple(fields["marker_ids"]), (), float(fields["reprojection_rms_px"]),
        fields["success"], fields["message"])
