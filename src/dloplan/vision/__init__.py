"""Experiment tooling: camera calibration, cable shape registration, planned-vs-measured errors.

Thesis 7.1-7.2. The image functions need the optional extra ``vision`` (OpenCV and
scikit-image, ``pip install dloplan[vision]``), imported only when one of them is called, so
``import dloplan.vision`` works without it; reading and writing registered shapes and the error
table need only numpy.

* :mod:`.camera` — pinhole intrinsics with distortion; reading an image file;
* :mod:`.transforms` — 4x4 rigid transforms (eqs. 7.1, 7.3);
* :mod:`.markers` — ArUco marker layout and detection with edge-refined corners;
* :mod:`.calibration` — extrinsic calibration A_c^r = A_m^r (A_m^c)^-1 (eq. 7.2), its JSON file;
* :mod:`.deprojection` — pixels with depth, or onto a plane, to 3D points;
* :mod:`.centreline` — the ordered centreline of one cable in a colour image;
* :mod:`.registration` — image -> registered shape of n + 1 points in the robot frame;
* :mod:`.shapes_io` — the registered-shape files (CSV, JSON);
* :mod:`.compare` — the error table of planned against registered shapes (Table 7.2).
"""

from .calibration import (
    ExtrinsicCalibration,
    calibrate_extrinsics,
    camera_to_robot_from_marker,
    read_calibration,
    write_calibration,
)
from .camera import CameraIntrinsics, normalize_pixels, project_normalized, read_image
from .centreline import Centreline, CentrelineError, HsvRange, extract_centreline
from .compare import ShapeComparison, compare_shapes, compare_trials
from .deprojection import deproject_depth, deproject_to_plane, depth_at_pixels
from .markers import (
    MarkerDetection,
    MarkerLayout,
    MarkerNotFoundError,
    detect_markers,
    marker_to_camera,
    read_marker_layout,
)
from .registration import register_on_plane, register_with_depth
from .shapes_io import RegisteredShape, read_shapes, write_shapes
from .transforms import invert_pose, pose_matrix, transform_points, transform_poses

__all__ = [
    "CameraIntrinsics", "Centreline", "CentrelineError", "ExtrinsicCalibration", "HsvRange",
    "MarkerDetection", "MarkerLayout", "MarkerNotFoundError", "RegisteredShape",
    "ShapeComparison", "calibrate_extrinsics", "camera_to_robot_from_marker", "compare_shapes",
    "compare_trials", "deproject_depth", "deproject_to_plane", "depth_at_pixels",
    "detect_markers", "extract_centreline", "invert_pose", "marker_to_camera",
    "normalize_pixels", "pose_matrix", "project_normalized", "read_calibration",
    "read_image", "read_marker_layout", "read_shapes", "register_on_plane", "register_with_depth",
    "transform_points", "transform_poses", "write_calibration", "write_shapes",
]
