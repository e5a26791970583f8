"""Robot arms from URDF descriptions: the serial chain from a base link to a tip link, its joint
limits and its collision geometry as capsules.

The URDF is read with ``yourdfpy`` (the ``robot`` extra; imported when a file is read), which
parses joints, links and collision elements; the kinematics of the chain is then evaluated in
plain numpy (:mod:`dloplan.robot.chain`), batched over joint vectors.

Conventions (URDF): joint i's frame sits at ``origin_i`` in its parent link's frame and turns
about ``axis_i`` by ``q_i``; its child link's frame is the joint frame after the turn. Fixed
joints along the chain are folded into the next revolute joint's origin (or into the tip
transform). Only revolute and continuous joints may move (prismatic joints on the path are
refused; side branches such as gripper fingers are not part of the chain).

Collision geometry becomes capsules (segment plus radius) in the frame of the moving link they
belong to:

- ``<cylinder>``: the capsule with the same axis and radius (it encloses the cylinder; the
  vendored descriptions write their capsules this way, so the round trip is exact);
- ``<sphere>``: a capsule of zero length;
- ``<box>``: the capsule along the box's longest axis through its centre enclosing the box;
- ``<mesh>``: one or two capsules enclosing the mesh vertices (:func:`capsules_from_points`),
  the mesh read with ``trimesh`` when its file resolves (else the link has no capsule).

Capsules over-approximate a link; capsule-capsule distances are closed form and fast
(:func:`dloplan.geometry.segment_distance`), which is why they are used rather than
convex meshes (see ``docs/cells.md``).
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from ..bounds import MAX_MESH_BYTES
from . import description_cache

MOVING = ("revolute", "continuous")
"""URDF joint types that move in the chain."""

DATA = "data"
"""Folder of the vendored descriptions in ``dloplan.robot`` (see its README.md)."""

CONTINUOUS_LIMIT = 2.0 * np.pi
"""[rad] Range +- this given to a ``continuous`` joint (a URDF continuous joint has none)."""


@dataclass(frozen=True, eq=False)
class ArmDescription:
    """One serial arm as read from a description, in its base link's frame.

    Joint i (0-based, n joints) has its frame at ``origin_xyz[i]``, turned by
    ``origin_rot[i]``, in the frame of link i-1 (link -1 is the base link); link i is the
    joint frame turned by ``q[i]`` about ``axes[i]``. The tip (flange) frame is fixed in link
    n-1 by ``tip_xyz`` / ``tip_rot``.

    Attributes
    ----------
    name : str
        Label (the tip link's name by default).
    joint_names : tuple of str
        (n,) URDF names of the moving joints, base to tip.
    origin_xyz : numpy.ndarray
        (n, 3) joint origins [m].
    origin_rot : numpy.ndarray
        (n, 3, 3) joint origin rotations (``joint_to_parent``).
    axes : numpy.ndarray
        (n, 3) unit joint axes in the joint frames.
    lower, upper : numpy.ndarray
        (n,) joint limits [rad].
    max_velocity : numpy.ndarray
        (n,) joint speed limits [rad/s] (inf where the description gives none).
    tip_xyz : numpy.ndarray
        (3,) tip frame origin in the last link's frame [m].
    tip_rot : numpy.ndarray
        (3, 3) tip frame rotation in the last link's frame.
    capsules : numpy.ndarray
        (m, 2, 3) capsule segment end points [m] in the frame of their link.
    capsule_link : numpy.ndarray
        (m,) int: the link each capsule moves with, 0..n-1, or -1 for the base link.
    radii : numpy.ndarray
        (m,) capsule radii [m].
    base_link, tip_link : str
        URDF link names the chain runs between.
    source : str
        Where the description came from (file path).
    """

    name: str
    joint_names: tuple[str, ...]
    origin_xyz: np.ndarray
    origin_rot: np.ndarray
    axes: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    max_velocity: np.ndarray
    tip_xyz: np.ndarray
    tip_rot: np.ndarray
    capsules: np.ndarray
    capsule_link: np.ndarray
    radii: np.ndarray
    base_link: str
    tip_link: str
    source: str

    def __post_init__(self) -> None:
        n = len(self.joint_names)
        if n < 1:
            raise ValueError(f"joint_names: the chain {self.base_link!r} -> {self.tip_link!r} "
                             "has no moving joint")
        shapes = {"origin_xyz": (n, 3), "origin_rot": (n, 3, 3), "axes": (n, 3), "lower": (n,),
                  "upper": (n,), "max_velocity": (n,), "tip_xyz": (3,), "tip_rot": (3, 3)}
        for key, shape in shapes.items():
            arr = np.asarray(getattr(self, key), dtype=float)
            if arr.shape != shape or np.any(np.isnan(arr)):
                raise ValueError(f"{key}: expected numbers (no NaN) of shape {shape}, got "
                                 f"{arr.tolist() if arr.size <= 12 else arr.shape}")
            object.__setattr__(self, key, arr)
        if np.any(self.lower >= self.upper):
            raise ValueError(f"joint limits of {self.name!r}: lower {self.lower} must be below "
                             f"upper {self.upper}")
        caps = np.asarray(self.capsules, dtype=float).reshape(-1, 2, 3)
        links = np.asarray(self.capsule_link, dtype=int).reshape(-1)
        radii = np.asarray(self.radii, dtype=float).reshape(-1)
        if not (len(caps) == len(links) == len(radii)) or np.any(radii < 0) or np.any(
                (links < -1) | (links >= n)):
            raise ValueError(f"capsules of {self.name!r}: {len(caps)} segments, {len(links)} "
                             f"links, {len(radii)} radii (>= 0, links in -1..{n - 1}) expected")
        object.__setattr__(self, "capsules", caps)
        object.__setattr__(self, "capsule_link", links)
        object.__setattr__(self, "radii", radii)
        object.__setattr__(self, "axes", self.axes / np.linalg.norm(self.axes, axis=1)[:, None])

    @property
    def n_joints(self) -> int:
        """Number of moving joints n."""
        return len(self.joint_names)


def capsule_from_points(points) -> tuple[np.ndarray, np.ndarray, float]:
    """The smallest capsule around points along one of six candidate axes.

    Candidates: the points' three principal directions and the three axes of their frame
    (links are often cylinders about a frame axis), each through the centroid. For each, the
    radius is the largest distance of a point from the line and the segment's ends are moved in
    from the extreme projections as far as the end spheres still enclose every point; the
    capsule of least volume is returned. It encloses every point (an over-approximation).

    Parameters
    ----------
    points : array_like
        (N, 3) vertices [m], N >= 1.

    Returns
    -------
    p0, p1 : numpy.ndarray
        (3,) segment end points [m].
    radius : float
        [m].
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 3)
    if len(pts) == 0 or not np.all(np.isfinite(pts)):
        raise ValueError(f"points: expected finite (N, 3) vertices, got shape {pts.shape}")
    centre = pts.mean(axis=0)
    rel = pts - centre
    candidates = np.concatenate([np.linalg.svd(rel, full_matrices=False)[2], np.eye(3)])
    best = None
    for axis in candidates:
        t = rel @ axis
        radial = np.linalg.norm(rel - t[:, None] * axis, axis=1)
        radius = float(radial.max())
        # The end sphere at t_hi encloses a point iff t - t_hi <= sqrt(r^2 - radial^2).
        cap = np.sqrt(np.maximum(radius**2 - radial**2, 0.0))
        t_hi, t_lo = float(np.max(t - cap)), float(np.min(t + cap))
        if t_lo > t_hi:
            t_lo = t_hi = 0.5 * (t_lo + t_hi)
        volume = np.pi * radius**2 * (t_hi - t_lo) + 4.0 / 3.0 * np.pi * radius**3
        if best is None or volume < best[0]:
            best = (volume, centre + t_lo * axis, centre + t_hi * axis, radius)
    return best[1], best[2], best[3]


SPLIT_GAIN = 0.8
"""A mesh is covered by two capsules instead of one when their volume is below this fraction of
the single capsule's (L-shaped links: a joint housing and a tube)."""


def capsules_from_points(points) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """One or two capsules enclosing points (a link's mesh vertices).

    The single capsule of :func:`capsule_from_points`, or, when cheaper by :data:`SPLIT_GAIN`
    in volume, two capsules fitted to the points on either side of a plane across the single
    capsule's axis (the plane tried at the 10 %, 20 %, ..., 90 % quantiles of the
    projections; each side keeps the points up to 1 mm beyond the plane so the halves
    overlap).

    Parameters
    ----------
    points : array_like
        (N, 3) vertices [m].

    Returns
    -------
    list of (p0, p1, radius)
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 3)
    single = capsule_from_points(pts)
    if len(pts) < 8:
        return [single]

    def volume(caps):
        return sum(np.pi * r**2 * np.linalg.norm(b - a) + 4.0 / 3.0 * np.pi * r**3
                   for a, b, r in caps)

    axis = single[1] - single[0]
    if np.linalg.norm(axis) < 1e-9:
        return [single]
    t = pts @ (axis / np.linalg.norm(axis))
    best, best_volume = [single], SPLIT_GAIN * volume([single])
    for cut in np.quantile(t, np.linspace(0.1, 0.9, 9)):
        low, high = pts[t <= cut + 1e-3], pts[t >= cut - 1e-3]
        pair = [capsule_from_points(low), capsule_from_points(high)]
        if volume(pair) < best_volume:
            best, best_volume = pair, volume(pair)
    return best


def _geometry_capsules(geometry, origin: np.ndarray, mesh_points) -> list[tuple]:
    """Capsules (p0, p1, r) of one URDF collision geometry in its link's frame."""
    rot, pos = origin[:3, :3], origin[:3, 3]
    if geometry.cylinder is not None:
        half = 0.5 * float(geometry.cylinder.length)
        ends = [pos + rot @ [0.0, 0.0, -half], pos + rot @ [0.0, 0.0, half]]
        return [(ends[0], ends[1], float(geometry.cylinder.radius))]
    if geometry.sphere is not None:
        return [(pos, pos, float(geometry.sphere.radius))]
    if geometry.box is not None:
        size = np.asarray(geometry.box.size, dtype=float)
        k = int(np.argmax(size))
        others = np.delete(size, k)
        radius = 0.5 * float(np.hypot(*others))
        half = max(0.5 * size[k] - radius, 0.0)
        direction = rot[:, k]
        return [(pos - half * direction, pos + half * direction, radius)]
    if geometry.mesh is not None:
        points = mesh_points(geometry.mesh)
        if points is None:
            return []
        scale = np.ones(3) if geometry.mesh.scale is None else np.broadcast_to(
            np.asarray(geometry.mesh.scale, dtype=float), (3,))
        return capsules_from_points((points * scale) @ rot.T + pos)
    return []


def _mesh_reader(urdf_path: Path, package_dirs: dict[str, str], looked_for: dict):
    """A function URDF mesh -> (N, 3) vertices [m] or None when the file does not resolve;
    every file it looks for is recorded in ``looked_for`` (path -> content digest, None when
    missing: what a kept parse depends on, :mod:`.description_cache`)."""

    def read(mesh):
        name = mesh.filename
        if name.startswith("package://"):
            package, _, rest = name[len("package://"):].partition("/")
            if package not in package_dirs:
                return None
            path = Path(package_dirs[package]) / rest
        elif name.startswith("file://"):
            path = Path(name[len("file://"):])
        else:
            path = urdf_path.parent / name
        looked_for[str(path.resolve())] = None
        if not path.is_file():
            return None
        if path.stat().st_size > MAX_MESH_BYTES:
            raise ValueError(f"{urdf_path}: mesh {name!r} has {path.stat().st_size / 1e6:.0f} "
                             f"MB, more than the {MAX_MESH_BYTES / 1e6:.0f} MB read for "
                             "collision capsules")
        looked_for[str(path.resolve())] = description_cache.file_digest(str(path))
        import trimesh

        try:
            loaded = trimesh.load(path, force="mesh")
            points = np.asarray(loaded.vertices, dtype=float).reshape(-1, 3)
        except Exception as exc:  # noqa: BLE001 - any reader's fault: named in one line
            raise ValueError(f"{urdf_path}: mesh {name!r} cannot be read ({exc})") from None
        if len(points) == 0 or not np.all(np.isfinite(points)):
            raise ValueError(f"{urdf_path}: mesh {name!r} has no finite vertices")
        return points

    return read


def read_urdf(path: Path, text: str):
    """A URDF file's ``text`` as a ``yourdfpy.URDF`` (the ``robot`` extra), without meshes or
    scene graph.

    The text (read by :func:`load_arm`) is parsed as XML here, so that what is not a URDF is
    refused with one line naming the file and the fault (yourdfpy would fall back to a
    recovering parser and fail later without saying why); a document type with entity
    declarations is refused (no entity is expanded).

    Raises
    ------
    ValueError
        Naming the file and what is wrong with it.
    """
    try:
        import yourdfpy
    except ImportError as exc:  # pragma: no cover - the robot extra is installed by make test
        raise ImportError("reading a URDF needs yourdfpy: pip install 'dloplan[robot]'") from exc
    from lxml import etree

    parser = etree.XMLParser(remove_blank_text=True, resolve_entities=False, no_network=True)
    try:
        root = etree.fromstring(text.encode("utf-8"), parser=parser)
    except etree.XMLSyntaxError as exc:
        raise ValueError(f"{path}: not a URDF file (not valid XML: {exc})") from None
    if root.getroottree().docinfo.internalDTD is not None:
        raise ValueError(f"{path}: a URDF file with a document type (<!DOCTYPE ...>) is not "
                         "read; expected plain XML")
    if root.tag != "robot":
        raise ValueError(f"{path}: not a URDF file (the root element is <{root.tag}>, expected "
                         "<robot>)")
    try:
        return yourdfpy.URDF.load(io.BytesIO(text.encode("utf-8")), build_scene_graph=False,
                                  load_meshes=False, build_collision_scene_graph=False,
                                  load_collision_meshes=False)
    except (KeyError, TypeError, ValueError, AttributeError, IndexError) as exc:
        detail = f"missing attribute {exc}" if isinstance(exc, KeyError) else str(exc)
        raise ValueError(f"{path}: not a valid URDF ({detail})") from None


def check_joint(path: Path, joint) -> None:
    """Refuse a joint of the chain whose numbers cannot move an arm: an origin or axis that is
    not finite, a zero axis, limits that are not finite or not ordered, a speed limit <= 0
    (ValueError naming the file, the joint, the value and what was expected)."""
    where = f"{path}: joint {joint.name!r}"
    origin = np.eye(4) if joint.origin is None else np.asarray(joint.origin, dtype=float)
    if not np.all(np.isfinite(origin)):
        raise ValueError(f"{where}: origin {origin[:3, 3].tolist()} (xyz), expected finite "
                         "numbers")
    if joint.type not in MOVING:
        return
    axis = np.asarray(joint.axis if joint.axis is not None else [1.0, 0.0, 0.0], dtype=float)
    if axis.shape != (3,) or not np.all(np.isfinite(axis)) or np.linalg.norm(axis) < 1e-9:
        raise ValueError(f"{where}: axis {axis.tolist()}, expected a finite non-zero vector")
    limit = joint.limit
    if limit is None:
        return
    bounds = [v for v in (limit.lower, limit.upper) if v is not None]
    if joint.type == "revolute" and (not np.all(np.isfinite(bounds)) or (
            len(bounds) == 2 and bounds[0] >= bounds[1])):
        raise ValueError(f"{where}: limits lower {limit.lower}, upper {limit.upper}, expected "
                         "finite numbers with lower < upper [rad]")
    if limit.velocity is not None and not (np.isfinite(limit.velocity) and limit.velocity > 0):
        raise ValueError(f"{where}: velocity limit {limit.velocity}, expected a number > 0 "
                         "[rad/s] (or none)")


def load_arm(path, tip_link: str, *, base_link: str | None = None, name: str | None = None,
             package_dirs: dict[str, str] | None = None) -> ArmDescription:
    """Read the serial chain from ``base_link`` to ``tip_link`` of a URDF file.

    Parameters
    ----------
    path : str or pathlib.Path
        URDF file.
    tip_link : str
        The chain's last link (the flange, e.g. ``tool0`` or ``panda_link8``).
    base_link : str, optional
        The link the arm is mounted by; default the URDF's root link. For one description with
        two arms, the common body (both arms' chains start there).
    name : str, optional
        Label of the arm; default ``tip_link``.
    package_dirs : dict, optional
        ``{"package": "/folder"}`` to resolve ``package://package/...`` mesh files (meshes
        that do not resolve give no capsule).

    Returns
    -------
    ArmDescription

    Notes
    -----
    The file is read once, bounded (:func:`dloplan.inputs.read_text`: a missing file, a
    symlink loop, a device or a folder, a file over 10 MB, binary data; the vendored URDFs have
    about 10 kB); its parse is kept on disk and used again while the file, the arguments and
    the mesh files are unchanged (:mod:`.description_cache`: no ``yourdfpy`` import then).
    """
    from ..inputs import read_text

    path = Path(path)
    text = read_text(path, kind="URDF file")
    key = description_cache.entry_key(path, text, tip_link, base_link, package_dirs)
    fields = description_cache.load(key)
    if fields is None:
        meshes: dict[str, str | None] = {}
        fields = parse_arm(path, text, tip_link, base_link, package_dirs or {}, meshes)
        description_cache.save(key, fields, meshes)
    return ArmDescription(name=name or tip_link, source=str(path), **fields)


def parse_arm(path: Path, text: str, tip_link: str, base_link: str | None,
              package_dirs: dict[str, str], meshes: dict) -> dict:
    """The fields of :func:`load_arm`'s :class:`ArmDescription` but its name and source, parsed
    from the URDF ``text`` of ``path``; ``meshes`` gets the mesh files looked for (path ->
    digest or None)."""
    robot = read_urdf(path, text).robot
    links = {link.name: link for link in robot.links}
    by_child = {joint.child: joint for joint in robot.joints}
    if tip_link not in links:
        raise ValueError(f"tip_link: {tip_link!r} is not a link of {path.name} "
                         f"(links: {', '.join(sorted(links))})")
    roots = sorted(set(links) - set(by_child))
    root = base_link if base_link is not None else roots[0]
    if root not in links:
        raise ValueError(f"base_link: {root!r} is not a link of {path.name}")
    chain = []
    link = tip_link
    while link != root:
        if link not in by_child:
            raise ValueError(f"base_link: {root!r} is not on the path from the root to "
                             f"{tip_link!r} in {path.name}")
        joint = by_child[link]
        chain.append(joint)
        link = joint.parent
    chain.reverse()
    mesh_points = _mesh_reader(path, package_dirs, meshes)

    names, xyz, rot, axes, lower, upper, speed = [], [], [], [], [], [], []
    caps, cap_link, radii = [], [], []
    pending = np.eye(4)  # fixed transforms since the last moving joint
    link_pose = {root: (np.eye(4), -1)}  # link -> (link_to_frame of its moving link, index)

    def add_capsules(link_name: str, to_frame: np.ndarray, index: int) -> None:
        for collision in links[link_name].collisions:
            origin = np.eye(4) if collision.origin is None else np.asarray(collision.origin)
            found = _geometry_capsules(collision.geometry, to_frame @ origin, mesh_points)
            for p0, p1, radius in found:
                if not (np.all(np.isfinite([*p0, *p1, radius])) and radius >= 0):
                    raise ValueError(f"{path}: link {link_name!r}: collision geometry gives "
                                     f"a capsule of radius {radius:g} m from {np.round(p0, 4)}"
                                     f" to {np.round(p1, 4)}; expected finite sizes >= 0")
            for p0, p1, radius in found:
                caps.append((p0, p1))
                radii.append(radius)
                cap_link.append(index)

    add_capsules(root, np.eye(4), -1)
    for joint in chain:
        origin = np.eye(4) if joint.origin is None else np.asarray(joint.origin, dtype=float)
        if joint.type in MOVING:
            transform = pending @ origin
            names.append(joint.name)
            xyz.append(transform[:3, 3])
            rot.append(transform[:3, :3])
            axes.append(np.asarray(joint.axis if joint.axis is not None else [1, 0, 0], float))
            limit = joint.limit
            if joint.type == "continuous" or limit is None or limit.lower is None:
                lower.append(-CONTINUOUS_LIMIT)
                upper.append(CONTINUOUS_LIMIT)
            else:
                lower.append(float(limit.lower))
                upper.append(float(limit.upper))
            velocity = None if limit is None else limit.velocity
            speed.append(float(velocity) if velocity else np.inf)
            pending = np.eye(4)
            link_pose[joint.child] = (np.eye(4), len(names) - 1)
        elif joint.type == "fixed":
            pending = pending @ origin
            link_pose[joint.child] = (pending.copy(), len(names) - 1)
        else:
            raise ValueError(f"{path.name}: joint {joint.name!r} of type {joint.type!r} on the "
                             f"chain to {tip_link!r}; only revolute, continuous and fixed "
                             "joints are supported")
        to_frame, index = link_pose[joint.child]
        add_capsules(joint.child, to_frame, index)
    for joint in chain:
        check_joint(path, joint)
    return dict(
        joint_names=tuple(names), origin_xyz=np.array(xyz).reshape(-1, 3),
        origin_rot=np.array(rot).reshape(-1, 3, 3), axes=np.array(axes).reshape(-1, 3),
        lower=np.array(lower), upper=np.array(upper), max_velocity=np.array(speed),
        tip_xyz=pending[:3, 3].copy(), tip_rot=pending[:3, :3].copy(),
        capsules=np.array(caps).reshape(-1, 2, 3), capsule_link=np.array(cap_link, dtype=int),
        radii=np.array(radii), base_link=root, tip_link=tip_link)


def vendored(filename: str) -> Path:
    """Path of a description shipped in ``dloplan/robot/data`` (``ur5e.urdf``, ``panda.urdf``,
    ``yumi.urdf``)."""
    path = Path(str(resources.files("dloplan.robot").joinpath(DATA, filename)))
    if not path.is_file():
        raise ValueError(f"filename: no vendored description {filename!r} in dloplan/robot/{DATA}")
    return path

