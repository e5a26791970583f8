"""Synthetic top-view camera scenes for the vision tests, rendered through known cameras.

A scene is a table (plane z = 0 of the robot frame) carrying ArUco markers and a coloured cable
of round cross-section lying flat on it (centreline at z = radius), photographed by a pinhole
camera with lens distortion. Every image pixel is rendered exactly: its ray (undistorted with
``cv2.undistortPoints``) is intersected with the table plane (markers) and with the plane of the
cable's centreline (cable), and the textures are sampled there; 3x3 supersampling gives
anti-aliased edges like a real camera's. The cable texture is drawn with OpenCV (filled quads per
link and discs at the joints: flat cut ends, round bends) at 0.2 mm per texel.
"""

from __future__ import annotations

import cv2
import numpy as np
from scipy.spatial.transform import Rotation

from dloplan.vision.camera import CameraIntrinsics
from dloplan.vision.transforms import pose_matrix

INTRINSICS = CameraIntrinsics(600.0, 600.0, 322.0, 238.0, 640, 480,
                              (0.08, -0.15, 0.001, -0.0005, 0.05))
TABLE_BGR = (150, 160, 165)  # unsaturated grey
CABLE_BGR = (200, 90, 20)  # saturated blue: OpenCV hue ~ 105
SECOND_BGR = (30, 40, 210)  # a red object


def look_at(eye, target, right=(0.0, -1.0, 0.0)) -> np.ndarray:
    """camera_to_robot of a camera at ``eye`` looking at ``target``, image x toward ``right``."""
    eye = np.asarray(eye, float)
    z = np.asarray(target, float) - eye
    z /= np.linalg.norm(z)
    x = np.asarray(right, float) - z * (np.asarray(right, float) @ z)
    x /= np.linalg.norm(x)
    return pose_matrix(Rotation.from_matrix(np.stack([x, np.cross(z, x), z], axis=1)), eye)


CAMERA_TO_ROBOT = look_at([0.38, 0.04, 0.62], [0.35, 0.0, 0.0], (0.1, -1.0, 0.0))
MARKER_LENGTH = 0.06
MARKER_POSES = {
    0: pose_matrix(Rotation.from_euler("z", 10, degrees=True), [0.20, 0.17, 0.0]),
    1: pose_matrix(Rotation.from_euler("z", -25, degrees=True), [0.50, 0.17, 0.0]),
    2: pose_matrix(Rotation.identity(), [0.50, -0.17, 0.0]),
    3: pose_matrix(Rotation.from_euler("z", 40, degrees=True), [0.20, -0.17, 0.0]),
}
DICTIONARY = cv2.aruco.DICT_4X4_50


def plane_maps(intrinsics, camera_to_robot, height, ss):
    """Robot-frame x, y (H*ss, W*ss) where the supersampled pixels' rays meet z = height.

    Computed once per camera, height and supersampling (the scenes of a test module share
    them; read-only arrays)."""
    key = (intrinsics, np.asarray(camera_to_robot, float).tobytes(), float(height), ss)
    if key not in _PLANE_MAPS:
        maps = _plane_maps(intrinsics, camera_to_robot, height, ss)
        for m in maps:
            m.flags.writeable = False
        _PLANE_MAPS[key] = maps
    return _PLANE_MAPS[key]


_PLANE_MAPS: dict = {}


def _plane_maps(intrinsics, camera_to_robot, height, ss):
    w, h = intrinsics.width, intrinsics.height
    u, v = np.meshgrid(np.arange(w, dtype=np.float32), np.arange(h, dtype=np.float32))
    n = cv2.undistortPoints(np.stack([u.ravel(), v.ravel()], 1).reshape(-1, 1, 2),
                            intrinsics.matrix, intrinsics.distortion_array).reshape(h, w, 2)
    n = cv2.resize(n, (w * ss, h * ss), interpolation=cv2.INTER_LINEAR)  # centre-aligned
    rot, origin = camera_to_robot[:3, :3], camera_to_robot[:3, 3]
    d = [rot[i, 0] * n[..., 0] + rot[i, 1] * n[..., 1] + rot[i, 2] for i in range(3)]
    s = (height - origin[2]) / d[2]
    return origin[0] + s * d[0], origin[1] + s * d[1]


def _paint_markers(img, x, y, markers, length):
    dictionary = cv2.aruco.getPredefinedDictionary(DICTIONARY)
    side, pad = 240, 60
    for marker_id, pose in markers.items():
        tex = cv2.aruco.generateImageMarker(dictionary, marker_id, side)
        tex = cv2.copyMakeBorder(tex, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=255)
        inv = np.linalg.inv(pose)
        mx = inv[0, 0] * x + inv[0, 1] * y + inv[0, 3]
        my = inv[1, 0] * x + inv[1, 1] * y + inv[1, 3]
        scale = length / side
        col = (mx / scale + side / 2 + pad - 0.5).astype(np.float32)
        row = (-my / scale + side / 2 + pad - 0.5).astype(np.float32)
        inside = (np.abs(mx) < length / 2 + pad * scale) & (np.abs(my) < length / 2 + pad * scale)
        grey = cv2.remap(tex, col, row, cv2.INTER_LINEAR)
        img[inside] = grey[inside, None]


def _cable_texture(points_xy, radius, origin, res, shape):
    """Mask texture (rows = y, cols = x) of a flat-ended round-jointed strip, 8-bit coverage."""
    tex = np.zeros(shape, np.uint8)
    shift = 4
    f = 2**shift

    def px(p):
        return np.rint(((np.asarray(p) - origin) / res - 0.5) * f).astype(np.int32)

    for a, b in zip(points_xy[:-1], points_xy[1:], strict=True):
        t = (b - a) / np.linalg.norm(b - a)
        n = np.array([-t[1], t[0]]) * radius
        quad = np.array([a + n, b + n, b - n, a - n])
        cv2.fillPoly(tex, [px(quad)], 255, cv2.LINE_AA, shift)
    for p in points_xy[1:-1]:
        cv2.circle(tex, tuple(int(c) for c in px(p)), int(round(radius / res * f)), 255, -1,
                   cv2.LINE_AA, shift)
    for end, inner in ((points_xy[0], points_xy[1]), (points_xy[-1], points_xy[-2])):
        t = (end - inner) / np.linalg.norm(end - inner)  # outward: cut the joint discs flat
        n = np.array([-t[1], t[0]]) * 1.5 * radius
        box = np.array([end + n, end + n + 2 * radius * t, end - n + 2 * radius * t, end - n])
        cv2.fillPoly(tex, [px(box)], 0, cv2.LINE_AA, shift)
    return tex


def _table(intrinsics, camera_to_robot, markers, marker_length, ss):
    """The table with its markers (H*ss, W*ss, 3) float32, drawn once per camera and markers
    (read-only: copy it to draw on)."""
    key = (intrinsics, np.asarray(camera_to_robot, float).tobytes(), marker_length, ss,
           tuple((k, np.asarray(p, float).tobytes()) for k, p in sorted(markers.items())))
    if key not in _TABLES:
        x0, y0 = plane_maps(intrinsics, camera_to_robot, 0.0, ss)
        img = np.empty(x0.shape + (3,), np.float32)
        img[:] = TABLE_BGR
        _paint_markers(img, x0, y0, markers, marker_length)
        img.flags.writeable = False
        _TABLES[key] = img
    return _TABLES[key]


_TABLES: dict = {}


def render(cables=(), markers=None, *, intrinsics=INTRINSICS, camera_to_robot=CAMERA_TO_ROBOT,
           marker_length=MARKER_LENGTH, ss=3):
    """A BGR uint8 image of the table with markers and cables.

    ``cables`` is a sequence of ``(points (k, 3) on the table [m], diameter [m], bgr)``: the
    centreline is drawn through the x-y of the points at height diameter / 2.
    """
    markers = MARKER_POSES if markers is None else markers
    img = _table(intrinsics, camera_to_robot, markers, marker_length, ss).copy()
    res = 0.0002
    for points, diameter, bgr in cables:
        xc, yc = plane_maps(intrinsics, camera_to_robot, diameter / 2, ss)
        pts = np.asarray(points, float)[:, :2]
        lo = pts.min(axis=0) - diameter
        size = np.ceil((pts.max(axis=0) + diameter - lo) / res).astype(int)
        tex = _cable_texture(pts, diameter / 2, lo, res, (size[1], size[0]))
        col = ((xc - lo[0]) / res - 0.5).astype(np.float32)
        row = ((yc - lo[1]) / res - 0.5).astype(np.float32)
        alpha = cv2.remap(tex, col, row, cv2.INTER_LINEAR, borderValue=0)[..., None] / 255.0
        img = img * (1 - alpha) + alpha * np.asarray(bgr, np.float32)
    w, h = intrinsics.width, intrinsics.height
    out = cv2.resize(img, (w, h), interpolation=cv2.INTER_AREA)
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)


def sine_cable(length=0.4, amplitude=0.05, n=200, centre=(0.35, 0.0), yaw=0.3):
    """A flat sine-shaped centreline of the given arc length (points on the table, z = 0)."""
    from dloplan.geometry import resample_by_arc_length, shape_length

    t = np.linspace(0.0, 1.0, 4001)
    extent = length
    for _ in range(30):  # fixed point on the extent for the wanted arc length
        curve = np.stack([t * extent, amplitude * np.sin(2 * np.pi * t), 0 * t], 1)
        extent *= length / shape_length(curve)
    curve[:, 0] -= extent / 2
    rot = Rotation.from_euler("z", yaw)
    curve = rot.apply(curve) + [*centre, 0.0]
    return resample_by_arc_length(curve, n)
