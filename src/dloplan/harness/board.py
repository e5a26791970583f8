"""The harness board: fixtures, pegs with plates, obstacles and the table (thesis 7.3, Fig. 7.26).

Frames and conventions (world frame, z up, SI units):

* a :class:`Fixture` is a slot the cable is clipped into. ``position`` is where the cable's
  axis lies once inserted (the bottom of the slot, at the clip point of the gripper holding
  that end); ``axis`` is the slot's direction, pointing **inward**, from the fixture toward the
  cable's route on the board -- the same convention as a clip's u-axis
  (:mod:`dloplan.sim.clips`), so at insertion the clip's u-axis equals the fixture's axis;
  ``opening`` is the direction the slot opens (the gripper comes from there and pushes the
  cable in against it, by ``depth``); ``slot_width`` must take the cable. Fixture 0 takes the
  cable's first end, fixture 1 its last.
* a :class:`Peg` is a vertical cylinder standing on the table; it may carry a horizontal plate
  whose top face, ``plate_height`` above the peg's base, is where the cable rests. ``side`` is
  the horizontal direction, from the peg's axis, on which the cable passes: the tensioned cable
  presses against the peg from that side.
* obstacles are :mod:`dloplan.obstacles` volumes; the table is a :class:`Table` plane.

:func:`check_board` rejects a board the cable cannot be used on, before any planning: a fixture
out of reach, a peg overlapping a fixture, a slot narrower than the cable, a plate above its
peg's top. The ``harness:`` section of a job file (file units) is
:mod:`dloplan.io.harness_spec`; :mod:`dloplan.app.resolve` builds the board from it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from ..cable import Cable
from ..obstacles.shapes import Box, Cylinder, Table

OPENING_TOLERANCE = math.radians(5.0)
"""A fixture's opening may deviate from perpendicular to its axis by this much [rad]."""


def _vector(name: str, value, size: int = 3) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.shape != (size,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: got {value!r}, expected {size} finite numbers")
    return arr


def _unit(name: str, value) -> np.ndarray:
    arr = _vector(name, value)
    norm = float(np.linalg.norm(arr))
    if norm < 1e-9:
        raise ValueError(f"{name}: got {value!r}, expected a non-zero direction")
    return arr / norm


def _length(name: str, value, allow_zero: bool = False) -> float:
    value = float(value)
    ok = math.isfinite(value) and (value >= 0 if allow_zero else value > 0)
    if not ok:
        bound = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{name}: got {value!r}, expected a length {bound} [m]")
    return value


@dataclass(frozen=True)
class Fixture:
    """A cable fixture (a clip on the board), see the module docstring for the frame.

    Parameters
    ----------
    position : array_like
        (3,) the cable's axis at the bottom of the slot, where the clip point sits once the
        cable is inserted [m].
    axis : array_like
        (3,) the slot's direction, pointing inward (normalized here).
    opening : array_like
        (3,) the direction the slot opens, perpendicular to ``axis`` within 5 degrees
        (normalized and made exactly perpendicular here); default up.
    slot_width : float
        Width of the slot [m]; at least the cable's diameter.
    depth : float
        Insertion depth [m]: how far the gripper pushes the cable into the slot.
    length : float
        Extent of the fixture along its axis [m] (its footprint, for overlap checks).
    wall : float
        Thickness of the slot's side walls [m] (footprint).
    name : str
        Label used in messages.
    """

    position: tuple[float, float, float]
    axis: tuple[float, float, float]
    opening: tuple[float, float, float] = (0.0, 0.0, 1.0)
    slot_width: float = 0.008
    depth: float = 0.01
    length: float = 0.015
    wall: float = 0.005
    name: str = "fixture"

    def __post_init__(self) -> None:
        position = _vector(f"{self.name}.position", self.position)
        axis = _unit(f"{self.name}.axis", self.axis)
        opening = _unit(f"{self.name}.opening", self.opening)
        if abs(float(axis @ opening)) > math.sin(OPENING_TOLERANCE):
            angle = math.degrees(math.acos(min(1.0, abs(float(axis @ opening)))))
            raise ValueError(
                f"{self.name}.opening: {tuple(self.opening)} makes {angle:.1f} degrees with the "
                f"axis {tuple(self.axis)}, expected perpendicular (within "
                f"{math.degrees(OPENING_TOLERANCE):.0f} degrees)"
            )
        opening = opening - (axis @ opening) * axis
        opening /= np.linalg.norm(opening)
        set_ = object.__setattr__
        set_(self, "position", tuple(float(v) for v in position))
        set_(self, "axis", tuple(float(v) for v in axis))
        set_(self, "opening", tuple(float(v) for v in opening))
        set_(self, "slot_width", _length(f"{self.name}.slot_width", self.slot_width))
        set_(self, "depth", _length(f"{self.name}.depth", self.depth, allow_zero=True))
        set_(self, "length", _length(f"{self.name}.length", self.length))
        set_(self, "wall", _length(f"{self.name}.wall", self.wall, allow_zero=True))

    @property
    def approach(self) -> np.ndarray:
        """(3,) the clip point before insertion: ``depth`` out of the slot along ``opening``."""
        return np.asarray(self.position) + self.depth * np.asarray(self.opening)

    def footprint(self) -> Box:
        """The fixture's body as a box (length along the axis, slot plus walls across), for
        overlap checks; yaw from the axis' horizontal direction."""
        axis = np.asarray(self.axis)
        yaw = math.atan2(axis[1], axis[0]) if np.hypot(axis[0], axis[1]) > 1e-9 else 0.0
        across = self.slot_width + 2.0 * self.wall
        return Box(self.position, (self.length, across, across), yaw, self.name)


@dataclass(frozen=True)
class Peg:
    """A vertical peg, optionally carrying a plate the cable rests on.

    Parameters
    ----------
    base : array_like
        (3,) centre of the peg's bottom face, on the table [m].
    radius : float
        Peg radius [m].
    height : float
        Peg height above its base [m].
    plate_height : float or None
        Height of the plate's top face above the peg's base [m] (below the peg's top), or None
        for a bare peg.
    plate_size : array_like
        (2,) plate extent along world x and y [m], centred on the peg.
    plate_thickness : float
        [m].
    side : array_like
        Horizontal direction from the peg's axis to the side the cable passes (the tensioned
        cable presses on the peg from there); default toward the robot (-x).
    name : str
        Label used in messages.
    """

    base: tuple[float, float, float]
    radius: float
    height: float
    plate_height: float | None = None
    plate_size: tuple[float, float] = (0.08, 0.08)
    plate_thickness: float = 0.003
    side: tuple[float, float, float] = (-1.0, 0.0, 0.0)
    name: str = "peg"

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "base", tuple(float(v) for v in _vector(f"{self.name}.base", self.base)))
        set_(self, "radius", _length(f"{self.name}.radius", self.radius))
        set_(self, "height", _length(f"{self.name}.height", self.height))
        side = _vector(f"{self.name}.side", self.side)
        side[2] = 0.0
        side = _unit(f"{self.name}.side (horizontal part)", side)
        set_(self, "side", tuple(float(v) for v in side))
        size = _vector(f"{self.name}.plate_size", self.plate_size, 2)
        if np.any(size <= 0):
            raise ValueError(f"{self.name}.plate_size: got {tuple(size)}, expected 2 lengths > 0")
        set_(self, "plate_size", tuple(float(v) for v in size))
        set_(self, "plate_thickness",
             _length(f"{self.name}.plate_thickness", self.plate_thickness))
        if self.plate_height is not None:
            h = _length(f"{self.name}.plate_height", self.plate_height)
            if h >= self.height:
                raise ValueError(
                    f"{self.name}.plate_height: got {h!r} m, expected below the peg's top "
                    f"({self.height!r} m): the cable rests on the plate against the peg"
                )
            if h < self.plate_thickness:
                raise ValueError(
                    f"{self.name}.plate_height: got {h!r} m, expected at least the plate "
                    f"thickness {self.plate_thickness!r} m"
                )
            set_(self, "plate_height", h)
        if min(size) <= 2 * self.radius:
            raise ValueError(
                f"{self.name}.plate_size: {tuple(size)} m does not extend beyond the peg "
                f"(diameter {2 * self.radius:g} m)"
            )

    def cylinder(self, inflate: float = 0.0) -> Cylinder:
        """The peg's volume, its radius grown by ``inflate`` [m].

        It reaches one radius below the peg's base: the peg stands in the board, and a point
        pressed into its foot must be pushed out sideways, not through its bottom face into the
        table (which pushes back: a penalty fight of hundreds of newtons in the statics)."""
        below = self.radius + inflate
        base = (self.base[0], self.base[1], self.base[2] - below)
        return Cylinder(base, self.radius + inflate, self.height + below, self.name)

    def plate(self) -> Box | None:
        """The plate's volume (a box centred on the peg), or None."""
        if self.plate_height is None:
            return None
        b = np.asarray(self.base)
        top = b[2] + self.plate_height
        return Box.from_corners(
            (b[0] - self.plate_size[0] / 2, b[1] - self.plate_size[1] / 2,
             top - self.plate_thickness),
            (b[0] + self.plate_size[0] / 2, b[1] + self.plate_size[1] / 2, top),
            name=f"{self.name} plate",
        )

    def volumes(self) -> tuple:
        """The peg and its plate (if any)."""
        plate = self.plate()
        return (self.cylinder(),) if plate is None else (self.cylinder(), plate)


@dataclass(frozen=True)
class Board:
    """A harness board: two fixtures, pegs, other obstacles and the table.

    Parameters
    ----------
    fixtures : tuple of Fixture
        Exactly two: for the cable's first and last end.
    pegs : tuple of Peg
        In any order (the route visits them by their position along the fixture chord).
    obstacles : tuple
        Other volumes (:class:`~dloplan.obstacles.Box`, :class:`~dloplan.obstacles.Cylinder`)
        the cable must avoid, e.g. between the start area and the board.
    table : Table or None
        The table plane.
    """

    fixtures: tuple[Fixture, Fixture]
    pegs: tuple[Peg, ...] = ()
    obstacles: tuple = ()
    table: Table | None = Table(0.0)

    def __post_init__(self) -> None:
        fixtures = tuple(self.fixtures)
        if len(fixtures) != 2 or not all(isinstance(f, Fixture) for f in fixtures):
            raise ValueError(f"fixtures: got {len(fixtures)} items, expected two Fixtures")
        pegs = tuple(self.pegs)
        if not all(isinstance(p, Peg) for p in pegs):
            raise ValueError("pegs: expected Peg objects")
        for k, obstacle in enumerate(self.obstacles):
            if not hasattr(obstacle, "signed_distance") or not hasattr(obstacle, "penetration"):
                raise ValueError(f"obstacles[{k}]: got {type(obstacle).__name__}, expected an "
                                 "obstacle volume (Box, Cylinder)")
        if self.table is not None and not isinstance(self.table, Table):
            raise ValueError(f"table: got {type(self.table).__name__}, expected a Table or None")
        set_ = object.__setattr__
        set_(self, "fixtures", fixtures)
        set_(self, "pegs", pegs)
        set_(self, "obstacles", tuple(self.obstacles))

    def route_pegs(self) -> tuple[Peg, ...]:
        """The pegs in the order the cable meets them, from fixture 0 to fixture 1."""
        a = np.asarray(self.fixtures[0].position)
        chord = np.asarray(self.fixtures[1].position) - a
        return tuple(sorted(self.pegs, key=lambda p: float((np.asarray(p.base) - a) @ chord)))

    def board_volumes(self) -> tuple:
        """Pegs and plates."""
        return tuple(v for peg in self.pegs for v in peg.volumes())

    def contacts(self) -> tuple:
        """Everything the cable cannot enter: pegs, plates, obstacles and the table."""
        table = () if self.table is None else (self.table,)
        return self.board_volumes() + self.obstacles + table

    def collision_volumes(self) -> tuple:
        """What the planned motion must avoid: :meth:`contacts`."""
        return self.contacts()


def board_to_dict(board: Board) -> dict:
    """The board's fixtures and pegs as JSON-ready data (SI units), for the plan document; its
    obstacles and table are the document's own ``obstacles``."""
    def plain(part) -> dict:
        return {f.name: (list(v) if isinstance(v := getattr(part, f.name), tuple) else v)
                for f in fields(part)}

    return {"fixtures": [plain(f) for f in board.fixtures], "pegs": [plain(p) for p in board.pegs]}


def board_from_dict(data: dict, volumes=(), where: str = "harness.board") -> Board:
    """The :class:`Board` of :func:`board_to_dict`'s data and the document's obstacle volumes
    (the pegs' own volumes among them are left out: the pegs make them again; a
    :class:`~dloplan.obstacles.Table` is the table).

    Raises
    ------
    ValueError
        Naming the part of ``data`` that is missing or invalid.
    """
    try:
        fixtures = tuple(Fixture(**f) for f in data["fixtures"])
        pegs = tuple(Peg(**p) for p in data["pegs"])
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"{where}: {exc}") from None
    own = {name for peg in pegs for name in (peg.name, f"{peg.name} plate")}
    tables = [v for v in volumes if isinstance(v, Table)]
    others = tuple(v for v in volumes if not isinstance(v, Table) and v.name not in own)
    return Board(fixtures, pegs, others, tables[0] if tables else None)


def route_length(board: Board, cable: Cable) -> float:
    """Length of the shortest route [m]: fixture 0, around each peg on its side, fixture 1.

    The polyline through the points where the cable's axis passes the pegs (at the peg's
    radius plus the cable's radius, on the peg's side), a lower bound of the cable length the
    route needs between the two clip points.
    """
    points = [np.asarray(board.fixtures[0].position)]
    for peg in board.route_pegs():
        b = np.asarray(peg.base)
        z = points[0][2]
        via = b + (peg.radius + cable.diameter / 2) * np.asarray(peg.side)
        points.append(np.array([via[0], via[1], z]))
    points.append(np.asarray(board.fixtures[1].position))
    return float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))


def check_board(board: Board, cable: Cable) -> None:
    """Reject a board the cable cannot be used on, before planning.

    Raises
    ------
    ValueError
        Naming the fixture or peg: a slot narrower than the cable; fixtures farther apart (or a
        route around the pegs longer) than the cable spans between its two clip points
        (L - l, the clips gripping the middle of the end links); a peg overlapping a fixture;
        a peg whose side points at a fixture's slot.
    """
    if not isinstance(board, Board):
        raise ValueError(f"board: got {type(board).__name__}, expected a harness Board")
    if not isinstance(cable, Cable):
        raise ValueError(f"cable: got {type(cable).__name__}, expected a dloplan.Cable")
    for fixture in board.fixtures:
        if fixture.slot_width < cable.diameter:
            raise ValueError(
                f"{fixture.name}.slot_width: {1e3 * fixture.slot_width:.2f} mm is narrower than "
                f"the cable ({1e3 * cable.diameter:.2f} mm diameter)"
            )
    span = cable.length - cable.rest_link_length
    f0, f1 = (np.asarray(f.position) for f in board.fixtures)
    distance = float(np.linalg.norm(f1 - f0))
    if distance >= span:
        raise ValueError(
            f"fixtures: {board.fixtures[0].name} and {board.fixtures[1].name} are "
            f"{distance:.4g} m apart, out of reach of the {cable.length:.4g} m cable (its clip "
            f"points are at most {span:.4g} m apart along it)"
        )
    if board.pegs:
        route = route_length(board, cable)
        if route >= span:
            raise ValueError(
                f"pegs: the route from {board.fixtures[0].name} around "
                f"{', '.join(p.name for p in board.route_pegs())} to {board.fixtures[1].name} "
                f"is at least {route:.4g} m long, out of reach of the {cable.length:.4g} m "
                f"cable ({span:.4g} m between its clip points)"
            )
    for peg in board.pegs:
        axis_point = np.asarray(peg.base)
        for fixture in board.fixtures:
            body = fixture.footprint()
            probe = np.array([axis_point[0], axis_point[1], body.center[2]])
            gap = float(body.distance(probe[None])[0]) - peg.radius
            if gap < cable.diameter:
                raise ValueError(
                    f"{peg.name}: overlaps {fixture.name} (the peg's surface is "
                    f"{1e3 * gap:.1f} mm from the fixture's body, expected at least the cable's "
                    f"diameter {1e3 * cable.diameter:.1f} mm)"
                )
