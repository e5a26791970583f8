"""A cable's centreline from a top-view colour image (thesis 7.1.2, Fig. 7.3; Fig. 6.4).

The thesis used Ariadne (super-pixels and a learned path search). Here, without network
weights: the cable is segmented by a colour range in HSV, thinned to a one-pixel skeleton
(``skimage.morphology.skeletonize``), and the skeleton is walked from one end to the other
along its longest geodesic path. Problems are reported, never guessed around: no cable, two
cable-coloured regions, a branch or a crossing. The ordered pixels are smoothed (a pixel
skeleton is a staircase whose length overestimates the cable's by up to 8 %) and extended
along the end tangents to the ends of the cable's region (the skeleton stops about half a
width short of a cut end).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage, sparse
from scipy.sparse import csgraph

from . import _deps


class CentrelineError(ValueError):
    """The image does not show exactly one cable without branches."""


@dataclass(frozen=True)
class HsvRange:
    """A colour range in OpenCV's HSV (H in [0, 180), S and V in [0, 255]).

    With ``low[0] > high[0]`` the hue range wraps around 180 (reds: low H 170, high H 10).
    """

    low: tuple[int, int, int]
    high: tuple[int, int, int]

    def __post_init__(self) -> None:
        for name in ("low", "high"):
            value = tuple(getattr(self, name))
            limits = (179, 255, 255)
            if len(value) != 3 or not all(
                    isinstance(v, int | np.integer) and 0 <= v <= m
                    for v, m in zip(value, limits, strict=True)):
                raise ValueError(
                    f"{name}: got {getattr(self, name)!r}, expected integers (H, S, V) with "
                    "H in [0, 179] and S, V in [0, 255] (OpenCV's HSV)"
                )
            object.__setattr__(self, name, tuple(int(v) for v in value))
        for k, channel in ((1, "S"), (2, "V")):
            if self.low[k] > self.high[k]:
                raise ValueError(
                    f"low, high: {channel} range {self.low[k]}..{self.high[k]} is empty")


@dataclass(frozen=True)
class Centreline:
    """An ordered cable centreline in the image.

    Attributes
    ----------
    pixels : numpy.ndarray
        (k, 2) points (u, v) [px] from one end of the cable to the other.
    width : float
        The cable's median apparent width [px].
    area : int
        Pixels of the cable's region.
    """

    pixels: np.ndarray
    width: float
    area: int

    @property
    def length(self) -> float:
        """Length of the pixel polyline [px]."""
        return float(np.linalg.norm(np.diff(self.pixels, axis=0), axis=1).sum())


def colour_mask(image, colour: HsvRange) -> np.ndarray:
    """Boolean mask (height, width) of the pixels of a BGR image inside the HSV range."""
    cv2 = _deps.cv2()
    img = np.asarray(image)
    if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
        raise ValueError(
            f"image: got shape {img.shape} dtype {img.dtype}, expected a (height, width, 3) "
            "uint8 BGR colour image"
        )
    if not isinstance(colour, HsvRange):
        raise ValueError(f"colour: expected an HsvRange, got {type(colour).__name__}")
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    low, high = np.array(colour.low), np.array(colour.high)
    if colour.low[0] <= colour.high[0]:
        mask = cv2.inRange(hsv, low, high)
    else:  # hue wraps around 180
        mask = cv2.inRange(hsv, low, np.array([179, *high[1:]])) | cv2.inRange(
            hsv, np.array([0, *low[1:]]), high)
    return mask > 0


def cable_region(image, colour: HsvRange, min_area: int = 50) -> np.ndarray:
    """The single connected region of the cable's colour, cleaned, (height, width) bool.

    Parameters
    ----------
    image : numpy.ndarray
        (height, width, 3) uint8 BGR image.
    colour : HsvRange
    min_area : int
        Regions smaller than this [px] are noise; holes smaller than this are filled.

    Raises
    ------
    CentrelineError
        No region of at least ``min_area`` pixels (no cable), or more than one (two cables,
        or a cable cut in two by an occlusion).
    """
    cv2 = _deps.cv2()
    if isinstance(min_area, bool) or int(min_area) != min_area or min_area < 1:
        raise ValueError(f"min_area: got {min_area!r}, expected an integer >= 1 [px]")
    mask = colour_mask(image, colour).astype(np.uint8)
    kernel = np.ones((3, 3), np.uint8)
    mask = cv2.morphologyEx(cv2.morphologyEx(mask, cv2.MORPH_OPEN, kernel), cv2.MORPH_CLOSE,
                            kernel)
    count, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    areas = stats[1:, cv2.CC_STAT_AREA]
    keep = np.nonzero(areas >= min_area)[0]
    if len(keep) == 0:
        largest = int(areas.max()) if len(areas) else 0
        raise CentrelineError(
            f"image: no cable found: no region of at least {min_area} px in the colour range "
            f"{colour.low}..{colour.high} (largest region: {largest} px)"
        )
    if len(keep) > 1:
        sizes = sorted((int(a) for a in areas[keep]), reverse=True)
        raise CentrelineError(
            f"image: {len(keep)} separate regions of the cable's colour ({sizes} px), expected "
            "one cable: two cables in view, or one cut by an occlusion; crop the image or "
            "narrow the colour range"
        )
    region = labels == keep[0] + 1
    holes, n_holes = ndimage.label(ndimage.binary_fill_holes(region) & ~region)
    sizes = np.bincount(holes.ravel(), minlength=n_holes + 1)
    small = np.nonzero(sizes < min_area)[0]
    return region | np.isin(holes, small[small > 0])  # fill glints, keep loops open


def _skeleton_graph(skeleton: np.ndarray):
    """Pixels (m, 2) as (row, col) and the 8-neighbour graph with Euclidean edge weights."""
    rows, cols = np.nonzero(skeleton)
    index = -np.ones(skeleton.shape, dtype=int)
    index[rows, cols] = np.arange(len(rows))
    padded = np.pad(index, 1, constant_values=-1)
    src, dst, weight = [], [], []
    for dr, dc in ((0, 1), (1, -1), (1, 0), (1, 1)):  # each undirected edge once
        nb = padded[rows + 1 + dr, cols + 1 + dc]
        ok = nb >= 0
        src.append(np.arange(len(rows))[ok])
        dst.append(nb[ok])
        weight.append(np.full(ok.sum(), math.hypot(dr, dc)))
    src, dst, weight = map(np.concatenate, (src, dst, weight))
    graph = sparse.coo_matrix((weight, (src, dst)), shape=(len(rows), len(rows))).tocsr()
    return np.column_stack([rows, cols]), graph + graph.T


def _ordered_skeleton(region: np.ndarray, width: float) -> np.ndarray:
    """The skeleton's pixels (k, 2) as (u, v) from one end to the other; errors on branches."""
    morphology = _deps.skimage_morphology()
    skeleton = morphology.skeletonize(region)
    pixels, graph = _skeleton_graph(skeleton)
    if len(pixels) < 2:
        raise CentrelineError("image: the cable's region is too small to have a centreline")
    degree = np.diff(graph.indptr)
    ends = np.nonzero(degree == 1)[0]
    if len(ends) < 2:
        raise CentrelineError(
            "image: the cable's centreline has no free ends (a closed loop): expected an open "
            "cable with two visible ends"
        )
    dist = csgraph.dijkstra(graph, indices=ends)
    dist_ends = dist[:, ends]
    dist_ends[~np.isfinite(dist_ends)] = -1.0
    i, j = np.unravel_index(np.argmax(dist_ends), dist_ends.shape)
    _, predecessors = csgraph.dijkstra(graph, indices=ends[i], return_predecessors=True)
    path = [ends[j]]
    while path[-1] != ends[i]:
        path.append(predecessors[path[-1]])
    path = np.array(path[::-1])
    # Every skeleton pixel must lie close to this path: farther ones form a branch or a loop.
    off_path = csgraph.dijkstra(graph, indices=path, min_only=True)
    spur = 1.5 * width + 3.0
    worst = int(np.argmax(off_path))
    if off_path[worst] > spur:
        row, col = pixels[worst]
        raise CentrelineError(
            f"image: the cable's centreline branches or crosses itself (a branch of "
            f"{off_path[worst]:.0f} px reaching pixel (u={col}, v={row})): expected one cable "
            "without crossings, not touching other objects of its colour"
        )
    return pixels[path][:, ::-1].astype(float)


def _extend_end(path: np.ndarray, region: np.ndarray, reach: float) -> np.ndarray:
    """The point where the path's end tangent leaves the region (the cable's cut end)."""
    back = path[min(len(path) - 1, max(int(round(reach)), 3))]
    tangent = path[0] - back
    norm = np.linalg.norm(tangent)
    if norm == 0.0:
        return path[0]
    tangent /= norm
    step = 0.25
    height, width = region.shape
    for k in range(1, int(4 * reach / step) + 1):
        u, v = np.rint(path[0] + k * step * tangent).astype(int)
        if not (0 <= u < width and 0 <= v < height) or not region[v, u]:
            return path[0] + (k - 0.5) * step * tangent
    return path[0] + 4 * reach * tangent


def extract_centreline(image, colour: HsvRange, *, min_area: int = 50,
                       smoothing: float = 2.0, start_near=None) -> Centreline:
    """The ordered centreline of the one cable of a colour in a top-view BGR image.

    Parameters
    ----------
    image : numpy.ndarray
        (height, width, 3) uint8 BGR image.
    colour : HsvRange
        The cable's colour range.
    min_area : int
        Smallest region counted as a cable [px] (smaller ones are noise).
    smoothing : float
        Standard deviation [px] of the Gaussian smoothing along the skeleton (removes the
        pixel staircase); 0 to keep the raw skeleton.
    start_near : array_like, optional
        A pixel (u, v): the centreline starts at the end nearer to it. Default: at the end
        with the smaller u (nearer the left image border).

    Returns
    -------
    Centreline

    Raises
    ------
    CentrelineError
        (a ValueError) for no cable, two cable-coloured regions, a closed loop, a branch or a
        crossing.
    """
    cv2 = _deps.cv2()
    if not (isinstance(smoothing, int | float) and math.isfinite(smoothing) and smoothing >= 0):
        raise ValueError(f"smoothing: got {smoothing!r}, expected a length >= 0 [px]")
    region = cable_region(image, colour, min_area)
    distance = cv2.distanceTransform(region.astype(np.uint8), cv2.DIST_L2, 5)
    morphology = _deps.skimage_morphology()
    width = float(2.0 * np.median(distance[morphology.skeletonize(region)]))
    path = _ordered_skeleton(region, width)
    if smoothing > 0 and len(path) > 2:
        path = ndimage.gaussian_filter1d(path, smoothing, axis=0, mode="nearest")
    # The skeleton forks toward the corners of a cut end: drop a width at each end, then
    # follow the tangent out to the end of the region.
    reach = max(width, 3.0)
    walked = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
    trim = min(reach, walked[-1] / 4)
    path = path[(walked >= trim) & (walked <= walked[-1] - trim)]
    path = np.vstack([_extend_end(path, region, 2 * reach), path,
                      _extend_end(path[::-1], region, 2 * reach)])
    if start_near is not None:
        near = np.asarray(start_near, dtype=float)
        if near.shape != (2,) or not np.all(np.isfinite(near)):
            raise ValueError(f"start_near: got {start_near!r}, expected a pixel (u, v)")
        if np.linalg.norm(path[-1] - near) < np.linalg.norm(path[0] - near):
            path = path[::-1]
    elif path[-1, 0] < path[0, 0]:
        path = path[::-1]
    return Centreline(path, width, int(region.sum()))
