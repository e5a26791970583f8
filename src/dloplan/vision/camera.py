"""Pinhole camera intrinsics with OpenCV's lens distortion model.

The intrinsics are what the thesis calls the internal calibration (7.1.1): a RealSense camera
reports them itself; any other camera gets them from ``cv2.calibrateCamera``. Pixel coordinates
are OpenCV's: (u, v) = (column, row), the centre of the top-left pixel at (0, 0). The camera
frame is OpenCV's: x to the right in the image, y down, z along the optical axis (into the
scene), metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import _deps

MAX_FOCAL = 1e6
"""Largest focal length [px] taken: a real camera's is some hundreds to thousands of pixels."""

MAX_SIDE = 100_000
"""Largest image side [px] taken."""


def _number(value) -> bool:
    """A real number (a bool, a string or a list is not)."""
    return isinstance(value, int | float | np.integer | np.floating) and not isinstance(
        value, bool | np.bool_)


@dataclass(frozen=True)
class CameraIntrinsics:
    """Focal lengths, principal point and distortion of a pinhole camera.

    Attributes
    ----------
    fx, fy : float
        Focal lengths [px].
    cx, cy : float
        Principal point [px].
    distortion : tuple of float
        OpenCV distortion coefficients (k1, k2, p1, p2[, k3[, k4, k5, k6]]); empty or zeros for
        none. A RealSense "Brown-Conrady" model gives exactly these five.
    width, height : int
        Image size [px] the intrinsics belong to.
    """

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int
    distortion: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        for name in ("fx", "fy"):
            value = getattr(self, name)
            if not (_number(value) and math.isfinite(value) and 0 < value <= MAX_FOCAL):
                raise ValueError(f"{name}: got {value!r}, expected a focal length > 0 and <= "
                                 f"{MAX_FOCAL:g} [px]")
        for name in ("width", "height"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= MAX_SIDE:
                raise ValueError(f"{name}: got {value!r}, expected an image size of 1 .. "
                                 f"{MAX_SIDE} [px]")
        for name, side in (("cx", self.width), ("cy", self.height)):
            value = getattr(self, name)
            if not (_number(value) and math.isfinite(value) and -side <= value <= 2 * side):
                raise ValueError(f"{name}: got {value!r}, expected a principal point within "
                                 f"-{side} .. {2 * side} px (the image is {side} px; near its "
                                 "middle for a real camera)")
        if not isinstance(self.distortion, list | tuple | np.ndarray) or not all(
                _number(d) for d in self.distortion):
            raise ValueError(
                f"distortion: got {self.distortion!r:.80}, expected a list of 0, 4, 5 or 8 "
                "finite OpenCV coefficients (k1, k2, p1, p2[, k3[, k4, k5, k6]])")
        dist = tuple(float(d) for d in self.distortion)
        if len(dist) not in (0, 4, 5, 8) or not all(math.isfinite(d) for d in dist):
            raise ValueError(
                f"distortion: got {self.distortion!r}, expected 0, 4, 5 or 8 finite OpenCV "
                "coefficients (k1, k2, p1, p2[, k3[, k4, k5, k6]])"
            )
        object.__setattr__(self, "distortion", dist)

    @property
    def matrix(self) -> np.ndarray:
        """The camera matrix K, (3, 3) [px]."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def distortion_array(self) -> np.ndarray:
        """The distortion coefficients as OpenCV takes them, (k,) (zeros(5) for none)."""
        return np.array(self.distortion) if self.distortion else np.zeros(5)

    @classmethod
    def from_matrix(cls, matrix, width: int, height: int, distortion=()) -> CameraIntrinsics:
        """Intrinsics from a 3x3 camera matrix K [px] and OpenCV distortion coefficients."""
        k = np.asarray(matrix, dtype=float)
        if k.shape != (3, 3):
            raise ValueError(f"matrix: expected a 3x3 camera matrix, got shape {k.shape}")
        return cls(float(k[0, 0]), float(k[1, 1]), float(k[0, 2]), float(k[1, 2]),
                   int(width), int(height), tuple(np.ravel(distortion)))

    def to_dict(self) -> dict:
        """A JSON-ready dict (pixels)."""
        return {"fx": self.fx, "fy": self.fy, "cx": self.cx, "cy": self.cy,
                "width": self.width, "height": self.height, "distortion": list(self.distortion)}

    @classmethod
    def from_dict(cls, data: dict, where: str = "intrinsics") -> CameraIntrinsics:
        """Inverse of :meth:`to_dict`; raises ValueError naming ``where`` and the bad field."""
        if not isinstance(data, dict):
            raise ValueError(f"{where}: expected a mapping, got {type(data).__name__}")
        missing = [k for k in ("fx", "fy", "cx", "cy", "width", "height") if k not in data]
        if missing:
            raise ValueError(f"{where}: missing {', '.join(missing)}")
        try:
            return cls(data["fx"], data["fy"], data["cx"], data["cy"], data["width"],
                       data["height"], data.get("distortion", ()))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{where}: {exc}") from exc

    def check_image(self, image, name: str = "image") -> np.ndarray:
        """Validate an image (height, width[, channels]) of these intrinsics' size."""
        arr = np.asarray(image)
        if arr.ndim not in (2, 3) or arr.shape[:2] != (self.height, self.width):
            size = (f"{arr.shape[1]} x {arr.shape[0]} px" if arr.ndim in (2, 3)
                    else f"an array of shape {arr.shape}")
            raise ValueError(
                f"{name}: got {size}, expected {self.width} x {self.height} px (array shape "
                f"({self.height}, {self.width}[, channels])), the intrinsics' width and height: "
                "an image of another camera or resolution"
            )
        return arr


def normalize_pixels(pixels, intrinsics: CameraIntrinsics) -> np.ndarray:
    """Undistorted normalized coordinates (x/z, y/z) of pixels, (k, 2) (``cv2.undistortPoints``).

    Parameters
    ----------
    pixels : array_like
        (k, 2) pixel coordinates (u, v) [px] in the (distorted) image.
    """
    cv2 = _deps.cv2()
    pts = np.ascontiguousarray(pixels, dtype=np.float64).reshape(-1, 1, 2)
    return cv2.undistortPoints(pts, intrinsics.matrix, intrinsics.distortion_array).reshape(-1, 2)


def project_normalized(normalized, intrinsics: CameraIntrinsics) -> np.ndarray:
    """Pixels (k, 2) [px] of normalized coordinates (x/z, y/z), lens distortion applied."""
    cv2 = _deps.cv2()
    norm = np.asarray(normalized, dtype=np.float64).reshape(-1, 2)
    rays = np.column_stack([norm, np.ones(len(norm))])
    pix, _ = cv2.projectPoints(rays, np.zeros(3), np.zeros(3), intrinsics.matrix,
                               intrinsics.distortion_array)
    return pix.reshape(-1, 2)


def read_image(path) -> np.ndarray:
    """The colour image (H, W, 3) uint8, OpenCV's BGR order, of an image file.

    Raises
    ------
    ImportError
        OpenCV is not installed (naming the extra: ``pip install dloplan[vision]``).
    ValueError
        The file cannot be read as an image (naming it).
    """
    if Path(path).is_dir():
        raise ValueError(f"{path}: is a folder; expected an image file")
    image = _deps.cv2().imread(str(path))
    if image is None:
        raise ValueError(f"{path}: cannot read the image; expected an image file OpenCV reads "
                         "(PNG, JPEG, BMP, TIFF)")
    return image
