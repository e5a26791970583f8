"""ArUco markers: the layout (which marker lies where in the robot frame) and their detection.

A marker's frame is OpenCV's: origin at the centre of the black square, x to the right and y up
as the marker is printed, z out of the paper. Its corners, in OpenCV's order (top-left,
top-right, bottom-right, bottom-left), are (-L/2, L/2, 0), (L/2, L/2, 0), (L/2, -L/2, 0),
(-L/2, -L/2, 0) for a side length L [m] (the black square, without the white quiet zone).

Detection is OpenCV's ``cv2.aruco.ArucoDetector`` with a predefined dictionary; its corners
are then refined from the marker's four outer edges (see :func:`detect_markers`), which
removes the ~0.2-0.5 px bias of OpenCV's corner refinement on the marker's L-shaped corners.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..inputs import parse_json, read_text
from ..io.poses import pose_from_dict
from . import _deps
from .camera import CameraIntrinsics, normalize_pixels, project_normalized
from .transforms import check_pose, pose_matrix

MARKER_CELLS_BORDER = 2  # one black border cell on each side of the marker's bit grid


class MarkerNotFoundError(ValueError):
    """None of the expected markers is visible in the image."""


def marker_corners(length: float) -> np.ndarray:
    """The marker's corners in its own frame, OpenCV's order, (4, 3) [m]."""
    h = length / 2.0
    return np.array([[-h, h, 0.0], [h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0]])


def _dictionary(name: str):
    cv2 = _deps.cv2()
    if not (isinstance(name, str) and name.startswith("DICT_") and hasattr(cv2.aruco, name)):
        raise ValueError(
            f"dictionary: got {name!r}, expected an OpenCV predefined ArUco dictionary name "
            "such as 'DICT_4X4_50' or 'DICT_6X6_250'"
        )
    return cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, name))


@dataclass(frozen=True)
class MarkerLayout:
    """Where the calibration markers lie in the robot base frame (the thesis' A_m^r).

    Attributes
    ----------
    marker_length : float
        Side of the black square [m].
    poses : mapping int -> (4, 4) array
        ``marker_to_robot`` homogeneous transform of each marker id [m].
    dictionary : str
        OpenCV predefined dictionary name, e.g. ``"DICT_4X4_50"``.
    frame_id : str
        Name of the frame the poses are given in.
    """

    marker_length: float
    poses: Mapping[int, np.ndarray]
    dictionary: str = "DICT_4X4_50"
    frame_id: str = "robot_base"

    def __post_init__(self) -> None:
        length = self.marker_length
        if not (isinstance(length, int | float) and math.isfinite(length) and length > 0):
            raise ValueError(f"marker_length: got {length!r}, expected a side length > 0 [m]")
        if not isinstance(self.poses, Mapping) or not self.poses:
            raise ValueError("poses: expected a non-empty mapping marker id -> 4x4 pose")
        checked = {}
        for key, pose in self.poses.items():
            if isinstance(key, bool) or not isinstance(key, int | np.integer) or key < 0:
                raise ValueError(f"poses: marker id {key!r} is not an integer >= 0")
            checked[int(key)] = check_pose(pose, f"poses[{key}]")
        object.__setattr__(self, "poses", checked)
        if not isinstance(self.dictionary, str) or not self.dictionary.startswith("DICT_"):
            raise ValueError(
                f"dictionary: got {self.dictionary!r}, expected an OpenCV dictionary name "
                "such as 'DICT_4X4_50'"
            )


def read_marker_layout(path) -> MarkerLayout:
    """Read a marker layout JSON file (format in docs/vision.md).

    ``{"dictionary": "DICT_4X4_50", "marker_length": 0.05, "frame_id": "robot_base",
    "markers": [{"id": 0, "pose": {"position": {x, y, z}, "orientation": {x, y, z, w}}}]}``
    with metres and a scalar-last quaternion.
    """
    where = str(path)
    text = read_text(path, kind="marker layout (JSON)")
    try:
        data = parse_json(text)
    except (ValueError, RecursionError) as exc:  # JSONDecodeError, a key twice
        raise ValueError(f"{where}: not a marker layout (not valid JSON: {exc})") from None
    if not isinstance(data, dict) or not isinstance(data.get("markers"), list):
        raise ValueError(f"{where}: expected an object with a 'markers' list")
    poses = {}
    for k, entry in enumerate(data["markers"]):
        if not isinstance(entry, dict) or "id" not in entry or "pose" not in entry:
            raise ValueError(f"{where}: markers[{k}] needs 'id' and 'pose'")
        if isinstance(entry["id"], int | float) and entry["id"] in poses:
            raise ValueError(f"{where}: markers[{k}].id: {entry['id']!r} given twice (markers"
                             f"[{list(poses).index(entry['id'])}] has it), expected one pose "
                             "per marker")
        position, quat = pose_from_dict(entry["pose"], f"{where}: markers[{k}].pose")
        poses[entry["id"]] = pose_matrix(Rotation.from_quat(quat), position)
    frame = data.get("frame_id", "robot_base")
    if not isinstance(frame, str) or not frame:
        raise ValueError(f"{where}: frame_id: got {frame!r:.60}, expected a frame name")
    try:
        layout = MarkerLayout(data.get("marker_length"), poses,
                              data.get("dictionary", "DICT_4X4_50"), frame)
        size = _dictionary(layout.dictionary).bytesList.shape[0]
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from exc
    beyond = [i for i in layout.poses if i >= size]
    if beyond:
        raise ValueError(f"{where}: marker id {beyond[0]} is not in {layout.dictionary} (ids "
                         f"0 .. {size - 1}): it can never be seen")
    return layout


@dataclass(frozen=True)
class MarkerDetection:
    """One detected marker.

    Attributes
    ----------
    marker_id : int
    corners : numpy.ndarray
        (4, 2) corners in the image [px], OpenCV's order.
    normalized : numpy.ndarray
        (4, 2) undistorted normalized image coordinates (x/z, y/z) of the corners.
    edge_refined : bool
        Whether the corners come from the edge fit (False: OpenCV's sub-pixel corners, e.g.
        for a marker too small or cut by the image border).
    """

    marker_id: int
    corners: np.ndarray
    normalized: np.ndarray
    edge_refined: bool


def _gray(image, intrinsics: CameraIntrinsics) -> np.ndarray:
    cv2 = _deps.cv2()
    img = intrinsics.check_image(image)
    if img.dtype != np.uint8:
        raise ValueError(f"image: got dtype {img.dtype}, expected an 8-bit image (uint8)")
    if img.ndim == 3:
        if img.shape[2] not in (3, 4):
            raise ValueError(f"image: got {img.shape[2]} channels, expected 1, 3 (BGR) or 4")
        img = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY if img.shape[2] == 3 else cv2.COLOR_BGRA2GRAY)
    return img


def _edge_points(gray: np.ndarray, a: np.ndarray, b: np.ndarray, outward: np.ndarray,
                 half: float) -> np.ndarray:
    """Sub-pixel points where the intensity crosses the mid level across the edge a -> b."""
    cv2 = _deps.cv2()
    edge = b - a
    n_samples = max(int(0.7 * np.linalg.norm(edge)), 5)
    ts = np.linspace(0.15, 0.85, n_samples)  # away from the corners
    offsets = np.linspace(-half, half, int(np.ceil(2 * half / 0.1)) + 1)
    grid = a + ts[:, None, None] * edge + offsets[None, :, None] * outward
    profile = cv2.remap(gray, grid[..., 0].astype(np.float32), grid[..., 1].astype(np.float32),
                        cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=-1.0)
    dark, bright = profile[:, :3].mean(axis=1), profile[:, -3:].mean(axis=1)
    ok = (bright - dark > 20.0) & np.all(profile >= 0.0, axis=1)  # contrast, inside the image
    level = profile - 0.5 * (dark + bright)[:, None]
    rising = (level[:, :-1] < 0.0) & (level[:, 1:] >= 0.0)
    ok &= rising.sum(axis=1) == 1  # exactly one dark -> bright crossing
    rows = np.nonzero(ok)[0]
    j = np.argmax(rising[rows], axis=1)
    frac = level[rows, j] / (level[rows, j] - level[rows, j + 1])
    offset = offsets[j] + frac * (offsets[1] - offsets[0])
    return a + ts[rows, None] * edge + offset[:, None] * outward


def _refine_by_edges(gray: np.ndarray, corners: np.ndarray, cells: int,
                     intrinsics: CameraIntrinsics) -> np.ndarray | None:
    """Corners (4, 2) in normalized coordinates from lines fitted to the four outer edges.

    Each edge is located at sub-pixel precision where the intensity crosses halfway between
    the black border and the white quiet zone (unbiased for a symmetric blur), the edge points
    are undistorted (the edges are straight lines only there) and a total-least-squares line is
    fitted to each edge; adjacent lines intersect at the corners. Returns None when an edge
    has too few usable points (marker too small, cut by the image border, low contrast).
    """
    side = float(np.mean(np.linalg.norm(np.roll(corners, -1, axis=0) - corners, axis=1)))
    cell = side / cells
    if cell < 3.0:
        return None
    centre = corners.mean(axis=0)
    lines = []
    for k in range(4):
        a, b = corners[k], corners[(k + 1) % 4]
        t = (b - a) / np.linalg.norm(b - a)
        outward = np.array([-t[1], t[0]])
        if outward @ (a - centre) < 0.0:
            outward = -outward
        points = _edge_points(gray.astype(np.float32), a, b, outward, half=0.4 * cell)
        if len(points) < 5:
            return None
        normalized = normalize_pixels(points, intrinsics)
        mean = normalized.mean(axis=0)
        direction = np.linalg.svd(normalized - mean)[2][0]
        lines.append((mean, direction))
    out = []
    for k in range(4):
        (p1, d1), (p2, d2) = lines[k - 1], lines[k]
        s = np.linalg.solve(np.column_stack([d1, -d2]), p2 - p1)
        out.append(p1 + s[0] * d1)
    return np.array(out)


def detect_markers(image, intrinsics: CameraIntrinsics, dictionary: str = "DICT_4X4_50", *,
                   refine_edges: bool = True) -> list[MarkerDetection]:
    """Detect ArUco markers and locate their corners at sub-pixel precision.

    Parameters
    ----------
    image : numpy.ndarray
        (height, width) grey or (height, width, 3) BGR uint8 image of the intrinsics' size.
    intrinsics : CameraIntrinsics
    dictionary : str
        OpenCV predefined dictionary name.
    refine_edges : bool
        Refine the corners from the marker's outer edges (default); otherwise keep OpenCV's
        ``CORNER_REFINE_SUBPIX`` corners.

    Returns
    -------
    list of MarkerDetection
        Sorted by marker id; empty if no marker is visible.
    """
    cv2 = _deps.cv2()
    if not isinstance(intrinsics, CameraIntrinsics):
        raise ValueError(f"intrinsics: expected CameraIntrinsics, got {type(intrinsics).__name__}")
    gray = _gray(image, intrinsics)
    aruco_dict = _dictionary(dictionary)
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    detector = cv2.aruco.ArucoDetector(aruco_dict, params)
    corners, ids, _ = detector.detectMarkers(gray)
    if ids is None:
        return []
    cells = aruco_dict.markerSize + MARKER_CELLS_BORDER
    found = []
    for quad, marker_id in zip(corners, ids.ravel(), strict=True):
        quad = quad.reshape(4, 2).astype(float)
        normalized = _refine_by_edges(gray, quad, cells, intrinsics) if refine_edges else None
        refined = normalized is not None
        if refined:
            quad = project_normalized(normalized, intrinsics)
        else:
            normalized = normalize_pixels(quad, intrinsics)
        found.append(MarkerDetection(int(marker_id), quad, normalized, refined))
    return sorted(found, key=lambda d: d.marker_id)


def marker_to_camera(detection: MarkerDetection, marker_length: float) -> np.ndarray:
    """The marker's pose in the camera frame, A_m^c (thesis 7.1.1), (4, 4) [m].

    OpenCV's ``solvePnP`` with ``SOLVEPNP_IPPE_SQUARE`` on the undistorted corners.
    """
    cv2 = _deps.cv2()
    ok, rvec, tvec = cv2.solvePnP(marker_corners(marker_length), detection.normalized,
                                  np.eye(3), np.zeros(5), flags=cv2.SOLVEPNP_IPPE_SQUARE)
    if not ok:
        raise ValueError(f"marker {detection.marker_id}: solvePnP found no pose")
    return pose_matrix(Rotation.from_rotvec(rvec.ravel()), tvec.ravel())
