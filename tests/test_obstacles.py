"""Obstacles: capsule collision checks, z_depth, stabilized checks and re-planning."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import level_clips, sagging_guess

from dloplan import catalogue_cable
from dloplan.obstacles import Box, Cylinder, Table, avoid_obstacles, check_path, check_shape
from dloplan.sim import equilibrium


def straight(z: float, n: int = 10, length: float = 0.5) -> np.ndarray:
    return np.stack([np.linspace(0, length, n + 1), np.zeros(n + 1), np.full(n + 1, z)], 1)


def test_a_link_crossing_a_thin_box_is_caught_where_points_are_not():
    wall = Box(center=(0.275, 0.0, 0.05), size=(0.004, 0.3, 0.1), name="wall")
    shape = straight(0.05)  # points every 5 cm: x = 0.25 and 0.30 straddle the 4 mm wall
    point_check = [wall.distance(p) == 0 for p in shape]
    assert not any(point_check)
    report = check_shape(shape, [wall], radius=0.0015)
    assert report.colliding and report.obstacles == ("wall",)
    assert report.links.tolist() == [5] and report.points.tolist() == [5, 6]


def test_z_depth_is_the_lift_that_clears_the_shape():
    box = Box.from_corners((0.1, -0.1, 0.0), (0.4, 0.1, 0.08), name="block")
    radius = 0.002
    shape = straight(0.05)
    report = check_shape(shape, [box], radius)
    assert report.z_depth == pytest.approx(0.08 + radius - 0.05)
    lifted = shape + [0, 0, report.z_depth + 1e-9]
    assert not check_shape(lifted, [box], radius).colliding
    assert check_shape(shape + [0, 0, report.z_depth - 1e-4], [box], radius).colliding


def test_rotated_box_and_cylinder_and_table():
    box = Box(center=(0.25, 0.0, 0.05), size=(0.02, 0.4, 0.1), yaw=np.pi / 2)  # now long in x
    assert check_shape(straight(0.05, length=0.5) + [0, 0.005, 0], [box], 0.001).colliding
    assert not check_shape(straight(0.05) + [0, 0.03, 0], [Box((0.25, 0, 0.05),
                                                              (0.02, 0.04, 0.1))], 0.001).colliding
    peg = Cylinder(base=(0.25, 0.0, 0.0), radius=0.01, height=0.06, name="peg")
    report = check_shape(straight(0.03), [peg], 0.002)
    assert report.colliding and report.z_depth == pytest.approx(0.06 + 0.002 - 0.03)
    table = Table(0.0)
    assert check_shape(straight(-0.001), [table], 0.002).penetration == pytest.approx(0.003)
    assert not check_shape(straight(0.01), [table], 0.002).colliding


def test_stabilization_reveals_a_collision_the_planned_shape_avoids():
    # thesis 5.4.2: a soft USB cable clears the box as planned, not once it sags under gravity
    cable = catalogue_cable("usb", n_links=20)
    clips = level_clips(0.4, z=0.2)
    planned = equilibrium(cable, sagging_guess(cable, 0.4, -0.05) + [0, 0, 0.2], clips,
                          gravity=(0, 0, 0)).shape
    settled = equilibrium(cable, planned, clips).shape
    drop = planned[:, 2] - settled[:, 2]
    k = int(drop.argmax())  # where gravity pulls the cable down most (a flank)
    assert drop[k] > 0.01
    top = 0.5 * (planned[k, 2] + settled[k, 2])
    x = settled[k, 0]
    box = Box.from_corners((x - 0.01, -0.1, 0.0), (x + 0.01, 0.1, top), name="box")
    radius = cable.diameter / 2
    assert not check_shape(planned, [box], radius).colliding
    report = check_shape(settled, [box], radius)
    assert report.colliding and report.z_depth > 0.003


def test_avoidance_reports_a_colliding_start_or_target():
    cable = catalogue_cable("pa12", n_links=10)
    path = np.stack([straight(0.05), straight(0.2), straight(0.3)])
    box = Box.from_corners((0.1, -0.1, 0.0), (0.4, 0.1, 0.1))

    def never(*args):
        raise AssertionError("must not re-plan when an end collides")

    result = avoid_obstacles(cable, path, [box], never)
    assert not result.success and result.status == "start_collides"
    assert "shape 0" in result.message
    assert check_path(result.stabilized, [box], 0.003)[0].colliding


@pytest.mark.parametrize(
    "make, fragment",
    [
        (lambda: Box((0, 0, 0), (0.1, -0.1, 0.1)), "size"),
        (lambda: Box((0, np.nan, 0), (0.1, 0.1, 0.1)), "center"),
        (lambda: Box.from_corners((0, 0, 0), (0.1, 0.1, -0.1)), "max corner"),
        (lambda: Cylinder((0, 0, 0), radius=0.0, height=0.1), "radius"),
        (lambda: Table(float("inf")), "height"),
    ],
)
def test_bad_obstacles_are_named(make, fragment):
    with pytest.raises(ValueError, match=fragment):
        make()


def test_a_path_through_a_wall_is_replanned_collision_free():
    from importlib import resources

    from dloplan.app import load_scenario
    from dloplan.physics import SpringChain, gradient
    from dloplan.planning import plan
    from dloplan.shapes import discretize
    from dloplan.sim.statics import force_scale

    with resources.as_file(resources.files("dloplan.data").joinpath("demo.yaml")) as path:
        job = load_scenario(path)  # an Ethernet cable over a wall
    cable = job.cable.with_links(10)
    start = discretize(job.start, cable, "start")
    target = discretize(job.target, cable, "target")
    free = plan(cable, start, target, 5)
    before = check_path(free.stabilized, job.obstacles, cable.diameter / 2)
    assert any(r.colliding for r in before)  # the direct path sags into the wall
    result = plan(cable, start, target, 5, obstacles=job.obstacles)
    avoidance = result.avoidance
    assert avoidance.success and avoidance.status == "replanned" and avoidance.rounds >= 1
    assert result.path.shape == (7, 11, 3)  # the asked-for S + 2 shapes
    assert not any(r.colliding for r in check_path(result.stabilized, job.obstacles,
                                                   cable.diameter / 2))
    # every shape is still a minimal-energy (weightless equilibrium) shape: the physical stage
    # ran on the re-planned parts
    weightless = SpringChain.from_cable(cable, gravity=(0, 0, 0))
    scale = force_scale(cable, (0, 0, 0))
    for shape in result.path[1:-1]:
        assert np.abs(gradient(weightless, shape)[2:-2]).max() < 1e-6 * scale
    # the clips move continuously: no jump between consecutive shapes
    clips = (result.path[:, :2].mean(axis=1), result.path[:, -2:].mean(axis=1))
    for points in clips:
        assert np.linalg.norm(np.diff(points, axis=0), axis=1).max() < 0.4 * cable.length


def test_compiled_box_penetration_is_the_smallest_distance_along_each_link():
    """The compiled capsule-box search against the distance sampled at 4001 points per link
    (any batch shape): never above the sampled minimum, and below it by at most the sampling's
    reach (the distance is 1-Lipschitz: half a sample spacing times the link length)."""
    rng = np.random.default_rng(0)
    box = Box((0.1, 0.02, 0.03), (0.05, 0.08, 0.04), 0.4)
    a = rng.normal(size=(4, 50, 3)) * 0.08 + [0.1, 0.0, 0.03]
    b = a + rng.normal(size=a.shape) * 0.03
    depth = box.penetration(a, b, 0.003)
    assert depth.shape == (4, 50)
    assert np.any(depth > 0) and np.any(depth < 0)
    t = np.linspace(0.0, 1.0, 4001)[:, None, None, None]
    sampled = box.distance(a + t * (b - a)).min(axis=0)
    found = 0.003 - depth
    assert np.all(found <= sampled + 1e-15)
    reach = 0.5 / 4000 * np.linalg.norm(b - a, axis=-1)
    assert np.all(found >= sampled - reach)
