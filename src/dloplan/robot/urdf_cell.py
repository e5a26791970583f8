"""Dual-arm cells built from robot descriptions, and a plan's verification on one.

The presets (:data:`PRESETS`): ``ur5e_pair`` (two UR5e side by side), ``panda_pair`` (two Franka
arms with the Franka Hand), ``yumi`` (the ABB YuMi, :func:`dloplan.robot.yumi.yumi`); a cell
from one URDF per arm (:func:`cell_from_specs`, a scenario's ``robot.cell`` section:
:func:`cell_from_mapping`), each a :class:`~dloplan.robot.described.DescribedCell`.
:func:`verify_on_cell` verifies a plan's timed trajectory on such a cell (the arm assignment,
the cell's placement search, :func:`~dloplan.robot.placement.search_cell_placement`, and the
path check, :func:`~dloplan.robot.path.check_path`) as the :class:`CellPlan` the vendor
writers are given.
"""

from __future__ import annotations

import inspect
import os
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from .assignment import assign_arms
from .chain import DEFAULT_TCP_IN_CLIP, CellArm, in_base_frame
from .described import ARMS, MIN_MARGIN, DescribedCell
from .description import load_arm, vendored
from .path import PathCheck, ReachOptions, check_path
from .placement import search_cell_placement
from .program import HeldArms
from .yumi import yumi


def _check_separation(separation) -> None:
    if not (np.isfinite(separation) and separation > 0):
        raise ValueError(f"robot.cell.separation: got {separation!r}, expected a distance > 0 "
                         "[m] between the two bases")


def ur5e_pair(*, separation: float = 0.8, tcp_offset: float = 0.15, tool_radius: float = 0.045,
              table_height: float = 0.0) -> DescribedCell:
    """Two UR5e side by side on a table, facing +x.

    The bases stand at ``(0, +-separation/2, table_height)``, each turned by pi about z so its
    zero pose points along +x; the tool is a gripper ``tcp_offset`` [m] along the flange z
    (e.g. a Robotiq 2F-85 with coupling, 0.15 m) drawn as a capsule of ``tool_radius``. Home:
    ``[0, -90, 90, -90, -90, 0]`` deg (elbow up, tool pointing down).
    """
    _check_separation(separation)
    description = load_arm(vendored("ur5e.urdf"), "tool0")
    home = np.radians([0.0, -90.0, 90.0, -90.0, -90.0, 0.0])
    turn = Rotation.from_rotvec([0.0, 0.0, np.pi])
    arms = [CellArm(side, replace(description, name=f"ur5e_{side}"),
                    base_position=(0.0, sign * separation / 2, table_height), base_rotation=turn,
                    tcp_offset=(0.0, 0.0, tcp_offset), tool_radius=tool_radius, home=home)
            for side, sign in zip(ARMS, (1.0, -1.0), strict=True)]
    return DescribedCell("ur5e_pair", *arms, table_height=table_height, source={
        "preset": "ur5e_pair", "separation": separation, "tcp_offset": tcp_offset,
        "tool_radius": tool_radius, "table_height": table_height})


PANDA_MAX_ACCELERATION = (15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0)
"""[rad/s^2] The Panda's joint acceleration limits (Franka Emika, "Robot and interface
specifications", Franka Control Interface documentation: ddq_max); its joint speed limits
(2.175 rad/s for joints 1-4, 2.61 for 5-7) are the description's."""

PANDA_TCP_IN_CLIP = Rotation.from_matrix(np.diag([1.0, -1.0, -1.0]))
"""TCP axes in the clip frame for the Franka Hand: TCP x = u (the cable), y = -v, z = -w."""

CABLE_ALONG = {"y": DEFAULT_TCP_IN_CLIP, "x": PANDA_TCP_IN_CLIP}
"""A scenario's ``cable_along`` (the TCP axis the held cable runs along; the gripper approaches
from above) -> ``tcp_in_clip``: ``y`` for fingers closing along TCP x (YuMi, default), ``x``
for fingers closing along TCP y (Franka Hand)."""


def panda_pair(*, separation: float = 0.8, table_height: float = 0.0) -> DescribedCell:
    """Two Franka Emika Panda arms with the Franka Hand side by side, facing +x.

    Bases at ``(0, +-separation/2, table_height)``; the TCP is the Franka Hand's (0.1034 m
    along the hand's z, between the fingertips), the fingers drawn as a 3 cm capsule from the
    hand to the TCP. Home: Franka's ready pose ``[0, -45, 0, -135, 0, 90, 45]`` deg. The
    hand's fingers close along its y-axis, so it holds a clip with the cable along TCP x and
    approaches from above (:data:`PANDA_TCP_IN_CLIP`).
    """
    _check_separation(separation)
    description = load_arm(vendored("panda.urdf"), "panda_hand", base_link="panda_link0")
    home = np.radians([0.0, -45.0, 0.0, -135.0, 0.0, 90.0, 45.0])
    arms = [CellArm(side, replace(description, name=f"panda_{side}"),
                    base_position=(0.0, sign * separation / 2, table_height),
                    tcp_offset=(0.0, 0.0, 0.1034), tool_radius=0.03, home=home,
                    tcp_in_clip=PANDA_TCP_IN_CLIP, max_acceleration=PANDA_MAX_ACCELERATION)
            for side, sign in zip(ARMS, (1.0, -1.0), strict=True)]
    return DescribedCell("panda_pair", *arms, table_height=table_height, source={
        "preset": "panda_pair", "separation": separation, "table_height": table_height})


def yumi_cell(*, table_height: float = 0.0) -> DescribedCell:
    """The ABB YuMi as a described cell: :func:`dloplan.robot.yumi.yumi` (body ``yumi_body`` at
    the world origin, the SmartGripper's TCP on tool0, ABB's home pose, the arm angle's
    plug-in) on a table at ``table_height``; the vendored ``yumi.urdf`` loads to the same chains
    (tested)."""
    return replace(yumi(table_height=table_height),
                   source={"preset": "yumi", "table_height": table_height})


@dataclass(frozen=True, eq=False)
class CellPlan:
    """A plan's trajectory verified on a cell: what the vendor writers are given.

    Attributes
    ----------
    cell : DescribedCell
    offset : numpy.ndarray
        (3,) translation [m] of the job found by the placement search (zeros without it).
    swapped : bool
        The trajectory's left clip went to the right arm (it lies on the robot's right).
    times : numpy.ndarray
        (K,) knot times [s], strictly increasing (knots where no arm moves dropped).
    positions : numpy.ndarray
        (K, 2, 3) TCP positions [m] in the world, offset applied.
    rotations : scipy.spatial.transform.Rotation
        (K * 2,) ``tcp_to_world``, pose-major (k, arm).
    verdict : PathCheck
        Its rows labelled by the plan's shapes.
    shapes : numpy.ndarray
        (K,) int, the plan's shape (trajectory knot) of each kept knot.
    """

    cell: DescribedCell
    offset: np.ndarray
    swapped: bool
    times: np.ndarray
    positions: np.ndarray
    rotations: Rotation
    verdict: PathCheck
    shapes: np.ndarray

    def base_poses(self) -> tuple[np.ndarray, np.ndarray]:
        """(K, 2, 3) TCP positions [m] and (K, 2, 3) rotation vectors [rad] in each arm's base
        frame (URScript's ``p[...]`` poses)."""
        mats = self.rotations.as_matrix().reshape(-1, 2, 3, 3)
        pairs = [in_base_frame(arm, self.positions[:, a], Rotation.from_matrix(mats[:, a]))
                 for a, arm in enumerate(self.cell.arms)]
        return (np.stack([p for p, _ in pairs], 1), np.stack([r for _, r in pairs], 1))


def verify_on_cell(cell: DescribedCell, trajectory, *, tcp_in_clip: Rotation | None = None,
                   place: bool | None = None, options: ReachOptions | None = None,
                   held: HeldArms | None = None) -> CellPlan:
    """Verify a plan's timed clip trajectory on a cell.

    The TCP holds each clip at the clip point with ``clip_to_world * tcp_in_clip`` (default
    each arm's :attr:`~dloplan.robot.chain.CellArm.tcp_in_clip`); the clip on the robot's
    left (larger y in :meth:`DescribedCell.to_base`) goes to the left arm; knots where no arm
    moves are dropped; with ``place`` (default ``cell.place``) the job is shifted by
    :func:`search_cell_placement`, else verified where it is. The verdict's rows are labelled
    by the plan's shapes (``"shape k"``, one knot per shape).

    Parameters
    ----------
    cell : DescribedCell
    trajectory : dloplan.trajectory.Trajectory
        Knot times [s], clip positions (K, 2, 3) [m] and rotations per arm.
    tcp_in_clip : scipy.spatial.transform.Rotation, optional
        The same mapping for both arms instead of the arms' own.
    place : bool, optional
    options : ReachOptions, optional
    held : HeldArms, optional
        The arms hold the cable at the first knot (the remaining motion of a corrected plan):
        the left arm keeps the clip it holds, the job keeps the plan's offset (no placement
        search) and the motion starts from the held joints (:func:`check_path`'s ``held``).
    """
    options = options if options is not None else ReachOptions.cell_program(
        min_margin=cell.min_margin)
    times = np.asarray(trajectory.times, dtype=float)
    keep = np.concatenate([[True], np.diff(times) > 0])
    pos = np.asarray(trajectory.positions, dtype=float)[keep]
    mats = np.stack([r.as_matrix() for r in trajectory.rotations], 1)[keep]
    swapped = (assign_arms(pos, cell).left_clip == 1 if held is None else
               int(tuple(trajectory.arm_clips)[0]) != held.left_clip)
    if swapped:
        pos, mats = pos[:, ::-1], mats[:, ::-1]
    mats = np.stack([mats[:, a] @ (tcp_in_clip or arm.tcp_in_clip).as_matrix()
                     for a, arm in enumerate(cell.arms)], 1)
    rot = Rotation.from_matrix(mats.reshape(-1, 3, 3))
    if held is not None:
        offset = np.asarray(held.offset, dtype=float)
        verdict = check_path(cell, pos + offset, rot, seeds=held.joints, options=options,
                             held=True)
    elif cell.place if place is None else place:
        offset, verdict = search_cell_placement(cell, pos, rot, options=options)
    else:
        offset, verdict = np.zeros(3), check_path(cell, pos, rot, options=options)
    shapes = np.flatnonzero(keep)
    rows = tuple(replace(row, label=f"shape {shapes[row.shape]}", shape=int(shapes[row.shape]))
                 for row in verdict.rows)
    return CellPlan(cell, np.asarray(offset, float), swapped, times[keep], pos + offset, rot,
                    replace(verdict, rows=rows), shapes)


PRESETS = {"ur5e_pair": ur5e_pair, "panda_pair": panda_pair, "yumi": yumi_cell}
"""Cell presets by name: a function of keyword settings returning a :class:`DescribedCell`."""


@dataclass(frozen=True)
class ArmSpec:
    """One arm of a cell given by paths (the scenario's ``robot.cell.arms`` entries).

    Parameters
    ----------
    urdf : str
        Path of the URDF.
    tip_link : str
    base_link : str, optional
    base_position : tuple
        (3,) [m].
    base_rpy : tuple
        (3,) URDF roll-pitch-yaw [rad] of ``base_to_world``.
    tcp_offset : tuple
        (3,) [m] in the tip frame.
    tool_radius : float
        [m].
    home : tuple, optional
        (n,) [rad].
    cable_along : str
        Key of :data:`CABLE_ALONG`.
    max_acceleration : tuple, optional
        (n,) published joint acceleration limits [rad/s^2].
    package_dirs : dict
        For :func:`~dloplan.robot.description.load_arm`.
    """

    urdf: str
    tip_link: str
    base_link: str | None = None
    base_position: tuple = (0.0, 0.0, 0.0)
    base_rpy: tuple = (0.0, 0.0, 0.0)
    tcp_offset: tuple = (0.0, 0.0, 0.0)
    tool_radius: float = 0.0
    home: tuple | None = None
    cable_along: str = "y"
    max_acceleration: tuple | None = None
    package_dirs: dict = field(default_factory=dict)


def _cable_along(value, side: str) -> Rotation:
    if value not in CABLE_ALONG:
        raise ValueError(f"robot.cell.arms.{side}.cable_along: got {value!r}, expected one of "
                         f"{sorted(CABLE_ALONG)}")
    return CABLE_ALONG[value]


def _check_home(where: str, home, description) -> None:
    """Refuse a home pose (rad) outside the description's joint limits, naming the joints in
    degrees (one line; the arm's own check printed the radians as a numpy array over two)."""
    lower, upper = np.degrees(description.lower), np.degrees(description.upper)
    outside = [f"joint {k + 1} {q:g} deg not in [{lo:.4g}, {hi:.4g}]"
               for k, (q, lo, hi) in enumerate(zip(np.degrees(home), lower, upper, strict=True))
               if not lo <= q <= hi]
    if outside:
        raise ValueError(f"{where}: {'; '.join(outside)}; expected a home pose within the "
                         "description's joint limits")


def cell_from_specs(name: str, left: ArmSpec, right: ArmSpec, *,
                    table_height: float = 0.0) -> DescribedCell:
    """A cell from one URDF per arm (or the same URDF with two tip links)."""
    arms = []
    for side, spec in zip(ARMS, (left, right), strict=True):
        try:
            description = load_arm(spec.urdf, spec.tip_link, base_link=spec.base_link,
                                   name=f"{name}_{side}", package_dirs=spec.package_dirs)
        except ValueError as exc:  # about tip_link / base_link, or about the URDF file
            field_name = str(exc).split(":", 1)[0]
            where = f"robot.cell.arms.{side}" + ("" if field_name in ("tip_link", "base_link")
                                                 else ".urdf")
            raise ValueError(f"{where}: {exc}") from None
        if spec.home is not None and len(spec.home) != description.n_joints:
            raise ValueError(f"robot.cell.arms.{side}.home_deg: got {len(spec.home)} values, "
                             f"expected {description.n_joints} (one per joint of "
                             f"{spec.tip_link!r})")
        if spec.home is not None:
            _check_home(f"robot.cell.arms.{side}.home_deg", spec.home, description)
        if spec.max_acceleration is not None and \
                len(spec.max_acceleration) != description.n_joints:
            raise ValueError(f"robot.cell.arms.{side}.max_acceleration: got "
                             f"{len(spec.max_acceleration)} values, expected "
                             f"{description.n_joints} (one per joint of {spec.tip_link!r})")
        arms.append(CellArm(side, description, base_position=spec.base_position,
                            base_rotation=Rotation.from_euler("xyz", spec.base_rpy),
                            tcp_offset=spec.tcp_offset, tool_radius=spec.tool_radius,
                            home=spec.home, tcp_in_clip=_cable_along(spec.cable_along, side),
                            max_acceleration=spec.max_acceleration))
    if (left.urdf, left.tip_link, left.base_link, tuple(left.base_position),
            tuple(left.base_rpy)) == (right.urdf, right.tip_link, right.base_link,
                                      tuple(right.base_position), tuple(right.base_rpy)):
        raise ValueError(f"robot.cell.arms: both arms are the chain to {left.tip_link!r} at "
                         f"base_position {list(left.base_position)}: one arm in the other's "
                         "place; expected two arms apart (base_position) or two chains of one "
                         "description (tip_link)")
    shared = (left.urdf == right.urdf and left.base_link == right.base_link
              and tuple(left.base_position) == tuple(right.base_position)
              and tuple(left.base_rpy) == tuple(right.base_rpy))
    return DescribedCell(name, *arms, table_height=table_height, shared_base=shared)



ARM_KEYS = {"urdf", "tip_link", "base_link", "base_position", "base_rpy", "tcp_offset",
            "tool_radius", "home_deg", "cable_along", "max_acceleration"}
"""Keys of one arm in a scenario's ``robot.cell.arms`` (angles in degrees, lengths in m,
``max_acceleration`` the published joint acceleration limits in rad/s^2)."""

LENGTH_KEYS = {"separation", "tcp_offset", "tool_radius", "table_height", "base_position"}
"""Keys of a cell mapping (a preset's settings, the cell's, an arm's) that are lengths: given in
the scenario's units, multiplied by its scale."""


def _scaled(mapping: dict, scale: float) -> dict:
    """The mapping with its lengths (:data:`LENGTH_KEYS`) in m."""
    def scale_value(key, value):
        if key not in LENGTH_KEYS or isinstance(value, bool):
            return value
        try:
            return (np.asarray(value, dtype=float) * scale).tolist()
        except (TypeError, ValueError):
            raise ValueError(f"robot.cell.{key}: got {value!r}, expected a length (a number or "
                             "a list of numbers)") from None
    return {key: scale_value(key, value) for key, value in mapping.items()}


def _numbers(field_name: str, value, count: int | None, unit: str) -> tuple[float, ...]:
    """``value`` as ``count`` finite numbers (any count for None), else a ValueError naming the
    field, the value and what was expected."""
    expected = f"{count} finite numbers [{unit}]" if count else \
        f"finite numbers [{unit}], one per joint"
    if isinstance(value, str | bytes | bool) or not isinstance(value, list | tuple):
        raise ValueError(f"{field_name}: got {value!r}, expected a list of {expected}")
    try:
        numbers = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{field_name}: got {value!r}, expected {expected}") from None
    if numbers.ndim != 1 or (count is not None and len(numbers) != count) or \
            not np.all(np.isfinite(numbers)) or any(isinstance(v, bool) for v in value):
        raise ValueError(f"{field_name}: got {value!r}, expected {expected}")
    return tuple(float(v) for v in numbers)


def _arm_spec(side: str, arm, folder, scale: float) -> tuple[ArmSpec, dict]:
    """One arm of a scenario's ``robot.cell.arms`` checked field by field (before any file is
    read): its :class:`ArmSpec` and its record (lengths in m, the URDF path absolute)."""
    where = f"robot.cell.arms.{side}"
    if not isinstance(arm, dict):
        raise ValueError(f"{where}: expected a mapping, got {arm!r}")
    extra = sorted(set(arm) - ARM_KEYS)
    missing = sorted({"urdf", "tip_link"} - set(arm))
    if extra or missing:
        what = (f"unknown key{'s' if len(extra) > 1 else ''} {', '.join(map(repr, extra))}"
                if extra else f"{' and '.join(missing)} missing")
        raise ValueError(f"{where}: {what} (got keys {sorted(arm)}); expected urdf, tip_link "
                         f"and some of {sorted(ARM_KEYS)}")
    for key in ("urdf", "tip_link", "base_link", "cable_along"):
        if key in arm and not (isinstance(arm[key], str) and arm[key]):
            raise ValueError(f"{where}.{key}: got {arm[key]!r}, expected a name (text)")
    urdf = Path(os.path.abspath(Path(folder) / arm["urdf"]))  # symlinks are the reader's
    for key, unit in (("base_position", "file units"), ("tcp_offset", "file units"),
                      ("base_rpy", "deg")):
        if key in arm:
            _numbers(f"{where}.{key}", arm[key], 3, unit)
    home = arm.get("home_deg")
    if home is not None:
        home = _numbers(f"{where}.home_deg", home, None, "deg")
    accel = arm.get("max_acceleration")
    if accel is not None:
        accel = _numbers(f"{where}.max_acceleration", accel, None, "rad/s^2")
        if min(accel) <= 0:
            raise ValueError(f"{where}.max_acceleration: got {arm['max_acceleration']!r}, "
                             "expected limits > 0 [rad/s^2], one per joint")
    radius = arm.get("tool_radius", 0.0)
    if isinstance(radius, bool) or not isinstance(radius, int | float) or \
            not (np.isfinite(radius) and radius >= 0):
        raise ValueError(f"{where}.tool_radius: got {radius!r}, expected a finite number >= 0 "
                         "[file units]")
    record = {**_scaled(arm, scale), "urdf": str(urdf)}
    spec = ArmSpec(str(urdf), arm["tip_link"], arm.get("base_link"),
                   tuple(record.get("base_position", (0.0, 0.0, 0.0))),
                   tuple(np.radians(arm.get("base_rpy", (0.0, 0.0, 0.0)))),
                   tuple(record.get("tcp_offset", (0.0, 0.0, 0.0))),
                   float(record.get("tool_radius", 0.0)),
                   None if home is None else tuple(np.radians(home)),
                   arm.get("cable_along", "y"), accel)
    return spec, record


def cell_from_mapping(data: dict, folder=".", scale: float = 1.0) -> DescribedCell:
    """The cell of a scenario's ``robot.cell`` section (``docs/cells.md``).

    Either ``{preset: name, <keyword settings of the preset>}`` or ``{arms: {left: {...},
    right: {...}}, table_height: h, name: n}`` with per arm the keys of :data:`ARM_KEYS`
    (``urdf`` relative to ``folder``; ``base_rpy`` and ``home_deg`` in degrees). Lengths
    (:data:`LENGTH_KEYS`) are in file units, ``scale`` [m per unit]. The cell records its
    ``source``: this mapping with lengths in m and URDF paths absolute.

    Raises
    ------
    ValueError
        Naming the field, the value and what was expected.
    """
    if not isinstance(data, dict):
        raise ValueError(f"robot.cell: expected a mapping, got {data!r}")
    if "preset" in data:
        settings = _scaled({k: v for k, v in data.items() if k != "preset"}, scale)
        if data["preset"] not in PRESETS:
            raise ValueError(f"robot.cell.preset: got {data['preset']!r}, expected one of "
                             f"{sorted(PRESETS)}")
        make = PRESETS[data["preset"]]
        allowed = set(inspect.signature(make).parameters)
        if set(settings) - allowed:
            raise ValueError(f"robot.cell: got {sorted(set(settings) - allowed)} for preset "
                             f"{data['preset']!r}, expected some of {sorted(allowed)}")
        for key, value in data.items():  # a preset's settings are lengths, one number each
            if key != "preset" and (isinstance(value, bool) or not isinstance(value, int | float)
                                    or not np.isfinite(value)):
                raise ValueError(f"robot.cell.{key}: got {value!r}, expected one finite number "
                                 f"[file units] (a setting of preset {data['preset']!r}; a "
                                 "vector or another pose needs `arms:`, docs/cells.md)")
        try:
            return make(**settings)
        except TypeError as exc:
            raise ValueError(f"robot.cell: preset {data['preset']!r}: {exc}") from None
    arms = data.get("arms")
    if isinstance(arms, dict) and set(arms) != set(ARMS):
        raise ValueError(f"robot.cell.arms: got {sorted(arms)}, expected the two arms "
                         f"{list(ARMS)}")
    if not isinstance(arms, dict):
        raise ValueError(f"robot.cell: expected `preset` or `arms` with keys {ARMS}, got "
                         f"{sorted(data)}")
    unknown = set(data) - {"arms", "table_height", "name"}
    if unknown:
        raise ValueError(f"robot.cell: unknown keys {sorted(unknown)}")
    specs, source = [], {"arms": {}, **_scaled({k: v for k, v in data.items() if k != "arms"},
                                               scale)}
    for side in ARMS:
        spec, source["arms"][side] = _arm_spec(side, arms[side], folder, scale)
        specs.append(spec)
    cell = cell_from_specs(str(data.get("name", "cell")), *specs,
                           table_height=float(source.get("table_height", 0.0)))
    return replace(cell, source=source)


def cell_from_record(data: dict) -> DescribedCell:
    """The cell of :meth:`DescribedCell.to_dict`'s data (a plan document's ``robot.cell``)."""
    if not isinstance(data, dict) or data.get("kind") != "described":
        raise ValueError(f"robot.cell: expected a described cell record, got {data!r}")
    mapping = {k: v for k, v in data.items()
               if k not in ("kind", "place", "writers", "min_margin")}
    return replace(cell_from_mapping(mapping), place=bool(data.get("place", True)),
                   writers=dict(data.get("writers") or {}),
                   min_margin=float(data.get("min_margin", MIN_MARGIN)))
