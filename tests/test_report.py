"""The HTML report: a self-contained page whose 3D view shows the real robot, checked in headless
Chromium (no JS error, arms, cable and table in the picture, the timeline moves the arms, the
page's forward kinematics equal dloplan's)."""

from __future__ import annotations

import json
import os
import re

import numpy as np
import pytest
from browser import CHROMIUM, Browser, body_data, is_subreaper
from scipy.spatial.transform import Rotation

from dloplan.app.report import arm_scene, report_robot
from dloplan.obstacles import Box, Table
from dloplan.plots.report import report_html, verdict_html, write_report
from dloplan.plots.robot_meshes import MODELS, load_model, match_model, model_parts
from dloplan.trajectory import dual_arm_trajectory

needs_chromium = pytest.mark.skipif(
    CHROMIUM is None, reason="Chromium is not installed (make browser; apt-get install chromium)")
in_the_browser = pytest.mark.xdist_group("test_report_browser")
"""The tests of the module's one Chromium (the ``browser`` fixture), on one worker."""
pytest.importorskip("yourdfpy")


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    """One headless Chromium for every page of this module (each page loaded afresh)."""
    with Browser(tmp_path_factory.mktemp("profile")) as chromium:
        yield chromium


def small_plan():
    s = np.linspace(0, 1, 11)
    shapes = np.stack([np.stack([0.1 + 0.4 * s, 0 * s + 0.1 * t, 0.1 + 0.05 * t * np.sin(
        np.pi * s)], 1) for t in np.linspace(0, 1, 5)])
    positions = shapes[:, [0, -1]]
    rotations = np.broadcast_to(np.eye(3), (5, 2, 3, 3))
    return shapes, positions, rotations


# -- the page as text --------------------------------------------------------------------------

def test_report_is_self_contained(tmp_path):
    shapes, positions, rotations = small_plan()
    box = Box((0.3, 0, 0.02), (0.05, 0.05, 0.04))
    page = report_html(title="test", shapes=shapes, clip_positions=positions,
                       clip_rotations=rotations, obstacles=[box],
                       summary=["3 shapes"], warnings=["careful </script>"],
                       tables=[("t", ["a"], [[1]])])
    # works offline: the only address is the XHTML namespace three.js names, never fetched
    assert set(re.findall(r"https?://[^\s\"'<>)]+", page)) <= {"http://www.w3.org/1999/xhtml"}
    assert page.count("<script") == 3 and page.count("</script>") == 3  # data, three.js, viewer
    assert "careful &lt;/script&gt;" in page
    assert "__" + "DATA__" not in page and "__" + "VIEWER__" not in page  # every part inserted
    with pytest.raises(ValueError, match="shapes"):
        report_html(title="x", shapes=np.zeros((3, 3)))
    with pytest.raises(ValueError, match="shape_times"):
        report_html(title="x", shapes=shapes, shape_times=[0.0, 1.0])


def test_verdict_banner_puts_the_failed_checks_first():
    checks = [{"name": "obstacles", "ok": True, "detail": "clear"},
              {"name": "robot: clearance", "ok": False, "detail": "-3 mm at shape 2"},
              {"name": "verification", "ok": True, "detail": ""},
              {"name": "robot: reach", "ok": False, "detail": "12 mm at shape 4"}]
    banner = verdict_html(checks, warnings=["twist"])
    assert "data-verdict='failed'" in banner and "verdict: FAILED (2 of 4 checks failed)" in banner
    order = [banner.index(name) for name in ("robot: clearance", "robot: reach", "obstacles",
                                             "verification")]
    assert order == sorted(order)  # failed first, each group in the pipeline's order
    assert "<li>twist</li>" in banner
    ok = verdict_html(checks[:1] + checks[2:3], warnings=["twist"])
    assert "data-verdict='warn'" in ok and "verdict: ok, with 1 warning (all 2 checks" in ok
    assert "data-verdict='ok'" in verdict_html([], ()) and "no checks were run" in verdict_html(
        [], ())


# -- the meshes: which robot, where its parts hang --------------------------------------------

def _cells():
    from dloplan.robot.urdf_cell import panda_pair, ur5e_pair, yumi_cell

    return {"ur5e": ur5e_pair(), "panda": panda_pair(), "yumi": yumi_cell()}


def _matrix(pose) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = Rotation.from_quat(pose["quaternion"]).as_matrix()
    t[:3, 3] = pose["xyz"]
    return t


def scene_frames(arm: dict, q) -> list[np.ndarray]:
    """World 4x4 frames of the base and of every link of a report arm at joints q (the page's
    scene graph: base, then per joint its origin and its turn about the axis), TCP last."""
    frame = _matrix(arm["base"])
    frames = [frame]
    for joint, angle in zip(arm["joints"], q, strict=True):
        turn = np.eye(4)
        turn[:3, :3] = Rotation.from_rotvec(np.multiply(joint["axis"], angle)).as_matrix()
        frame = frame @ _matrix(joint) @ turn
        frames.append(frame)
    return frames + [frame @ _matrix(arm["tcp"])]


def _vertices(key: str) -> np.ndarray:
    model, mesh = key.split("/")
    manifest, arrays = load_model(model)
    points = []
    for piece in manifest["meshes"][mesh]["pieces"]:
        lo, hi = arrays[f"{piece['key']}/bounds"].astype(float)
        points.append(lo + (hi - lo) * arrays[f"{piece['key']}/positions"] / 65535.0)
    return np.concatenate(points)


def _outside(points, ends, radii) -> np.ndarray:
    """Distance [m] of each point outside the nearest capsule (negative: inside)."""
    a, b = ends[:, 0], ends[:, 1]
    ab = b - a
    t = np.clip(np.einsum("pmk,mk->pm", points[:, None] - a, ab)
                / np.maximum(np.einsum("mk,mk->m", ab, ab), 1e-12), 0.0, 1.0)
    nearest = a + t[..., None] * ab
    return (np.linalg.norm(points[:, None] - nearest, axis=-1) - radii).min(axis=1)


def test_every_preset_arm_gets_its_models_meshes_and_a_moved_joint_gets_none():
    for model, cell in _cells().items():
        for arm in cell.arms:
            joints = arm_scene(arm)["joints"]
            assert match_model(joints) == model
            parts, gripper = model_parts(model, [j["name"] for j in joints])
            assert gripper == (model != "ur5e") and {p["link"] for p in parts} >= set(
                range(-1, len(joints)))  # every link carries a mesh
            moved = [dict(j) for j in joints]
            moved[2] = {**moved[2], "xyz": list(np.add(moved[2]["xyz"], [0.0, 0.0, 1e-3]))}
            assert match_model(moved) is None  # a borrowed joint name is not enough
    assert match_model([{"name": "joint_a", "xyz": [0, 0, 0], "quaternion": [0, 0, 0, 1],
                         "axis": [0, 0, 1]}]) is None
    assert set(MODELS) == {"yumi", "ur5e", "panda"}


def test_the_meshes_hang_where_the_collision_capsules_are():
    """Each visual mesh placed by the page's chain at random joints lies where dloplan's own
    collision capsules of that arm are (independent data: fitted to the YuMi's and the Panda's
    meshes in dloplan, hand-made for the UR5e). Every part's centre lies inside the capsules (a
    mesh on the wrong link or turned in its frame would not); the YuMi's meshes lie within the
    capsules to 5 mm (decimation moves a surface by up to ~4 mm), >= 95 % of the Panda's
    vertices (the visual meshes of links 1 and 2 stick out of the capsules fitted to the
    collision meshes by up to ~2 cm)."""
    from dloplan.robot.chain import capsules
    from dloplan.robot.kinematics import link_frames

    rng = np.random.default_rng(3)
    for model, cell in _cells().items():
        for arm in cell.arms:
            scene = arm_scene(arm)
            parts, _ = model_parts(model, [j["name"] for j in scene["joints"]])
            for q in rng.uniform(arm.lower / 2, arm.upper / 2, (3, arm.n_joints)):
                frames = scene_frames(scene, q)
                frames_fk = link_frames(arm, q)  # dloplan's FK: the page's links are its links
                rot, pos = frames_fk.rotations, frames_fk.positions
                np.testing.assert_allclose(np.stack([f[:3, 3] for f in frames[1:]]), pos,
                                           atol=1e-9)
                np.testing.assert_allclose(np.stack([f[:3, :3] for f in frames[1:]]), rot,
                                           atol=1e-9)
                ends, radii, _ = capsules(arm, q)
                gaps = []
                for part in parts:
                    if part["link"] < 0 and model == "yumi":
                        continue  # the YuMi's body has no capsule (the arms never reach it)
                    placed = frames[part["link"] + 1] @ _matrix(part)
                    v = _vertices(part["mesh"]) @ placed[:3, :3].T + placed[:3, 3]
                    assert _outside(v.mean(axis=0)[None], ends, radii)[0] < 0, part
                    gaps.append(_outside(v, ends, radii))
                gaps = np.concatenate(gaps)
                if model == "yumi":
                    assert gaps.max() < 5e-3
                if model == "panda":
                    assert np.mean(gaps < 5e-3) > 0.95


# -- the program as the report's data ----------------------------------------------------------

def _clip_trajectory(x: float = 0.8):
    """A cable held at both ends in front of a cell, lifted 5 cm while they come 10 cm closer."""
    n = 5
    pos = np.zeros((n, 2, 3))
    for k, t in enumerate(np.linspace(0, 1, n)):
        pos[k, 0] = [x, -0.2 + 0.05 * t, 0.1 + 0.05 * t]
        pos[k, 1] = [x, 0.2 - 0.05 * t, 0.1 + 0.05 * t]
    clip = Rotation.from_matrix(np.tile(np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0],
                                                  [0.0, 0.0, 1.0]]), (n, 1, 1)))
    return dual_arm_trajectory(pos, (clip, clip)), clip


def _cell_plan(cell):
    """A verified program of ``cell`` and the page's keyword arguments: the cable sagging
    between the clips of every shape."""
    from dloplan.robot.tracked_program import tracked_program

    trajectory, clip = _clip_trajectory()
    program = tracked_program(cell, trajectory)
    s = np.linspace(0.0, 1.0, 13)[:, None]
    ends = np.asarray(trajectory.positions)
    shapes = ends[:, None, 0] + s * (ends[:, None, 1] - ends[:, None, 0])
    shapes[..., 2] -= 0.08 * np.sin(np.pi * s[:, 0])
    return program, dict(shapes=shapes, clip_positions=ends,
                         clip_rotations=np.repeat(clip.as_matrix()[:, None], 2, axis=1),
                         obstacles=[Table(0.0)], cable_radius=0.003,
                         robot=report_robot(program))


def _tcp(program, arm_index: int, q) -> np.ndarray:
    """dloplan's FK of the program's arm in the plan's frame (one kinematics for every arm)."""
    from dloplan.robot.kinematics import forward

    arm = program.cell.arms[arm_index]
    offset = np.asarray(program.to_dict().get("offset", (0.0, 0.0, 0.0)))
    return forward(arm, q)[0] - offset


def test_report_robot_is_the_programs_verified_joints_at_its_times():
    from dloplan.robot.urdf_cell import panda_pair

    program, _ = _cell_plan(panda_pair())
    record = program.to_dict()
    assert np.linalg.norm(record["offset"]) > 0  # the placement search moved this job
    robot = report_robot(program)
    assert robot["times"] == [t["time"] for t in record["targets"]]
    assert robot["shapes"] == [t["shape"] for t in record["targets"]]
    for a, arm in enumerate(program.cell.arms):
        np.testing.assert_allclose(robot["joints"][a], program.joints[a], atol=1e-12)
        for k, q in enumerate(robot["joints"][a]):
            # the page's chain puts the TCP where dloplan's FK does, in the plan's frame
            np.testing.assert_allclose(scene_frames(robot["arms"][a], q)[-1][:3, 3],
                                       _tcp(program, a, q), atol=1e-9)
            target = record["targets"][k]["arms"][arm.name]["position"]
            np.testing.assert_allclose(_tcp(program, a, q), np.subtract(target, record["offset"]),
                                       atol=1e-4)
    with pytest.raises(ValueError, match="robot.joints of arm 'left'"):
        report_html(title="x", shapes=np.zeros((5, 3, 3)),
                    robot={**robot, "joints": [robot["joints"][0][:, :3], robot["joints"][1]]})
    with pytest.raises(ValueError, match="robot.shapes"):
        report_html(title="x", shapes=np.zeros((2, 3, 3)), robot=robot)


def test_report_robot_of_a_yumi_program_puts_the_tcp_where_dloplans_fk_does():
    """The YuMi's own arms (not a described cell): approach and retreat targets included."""
    from dloplan.grippers import GripperPath
    from dloplan.robot import robot_program

    trajectory, clip = _clip_trajectory(0.4)
    grippers = GripperPath(np.asarray(trajectory.positions), (clip, clip), "minimal",
                           np.zeros(len(trajectory.times)))
    program = robot_program(grippers, trajectory)
    robot = report_robot(program)
    assert len(robot["times"]) == len(trajectory.times) + 2  # approach and retreat
    assert robot["shapes"][0] == robot["shapes"][1] == 0 and robot["shapes"][-1] == 4
    for a in range(2):
        for q in robot["joints"][a]:
            np.testing.assert_allclose(scene_frames(robot["arms"][a], q)[-1][:3, 3],
                                       _tcp(program, a, q), atol=1e-9)
    assert [match_model(arm["joints"]) for arm in robot["arms"]] == ["yumi", "yumi"]


# -- in the browser ----------------------------------------------------------------------------

def _canvas(html: str, pixels: np.ndarray) -> np.ndarray:
    left, top, width, height = json.loads(body_data(html)["canvas"])
    return pixels[top:top + height, left:left + width].astype(int)


def _changed(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs(a - b).sum(axis=-1) > 30


def _tan(pixels: np.ndarray) -> np.ndarray:
    """The table top's colour (sRGB 217, 199, 168 lit and shaded): warm and light."""
    r, g, b = (pixels[..., k] for k in range(3))
    return (r > 120) & (r - b > 25) & (r - b < 80) & (g > b) & (r >= g)


@needs_chromium
@in_the_browser
def test_the_yumi_report_shows_arms_cable_and_table_and_the_timeline_moves_the_arms(tmp_path,
                                                                                  browser):
    from robot_plans import example_plan

    from dloplan.robot import robot_program

    shapes, grippers, trajectory, job = example_plan("m2_uniform_curvature_usb.yaml")
    program = robot_program(grippers, trajectory)
    robot = report_robot(program)
    page = write_report(tmp_path / "report.html", title="yumi", shapes=shapes,
                        stabilized=shapes - [0, 0, 0.002], clip_positions=grippers.positions,
                        clip_rotations=grippers.matrices, cable_radius=0.004,
                        obstacles=list(job.obstacles) + [Table(0.0)], robot=robot)
    html, messages = browser.dom(page)
    data = body_data(html)
    assert data["rendered"] == "true" and data["webgl"] == "true" and "errors" not in data
    assert messages == []  # no error, no warning, nothing logged
    middle = robot["times"][len(robot["times"]) // 2]
    shots = {}
    for name, fragment in (("start", ""), ("no robot", "hide=robot"),
                           ("no cable", "hide=planned,stabilized"), ("middle", f"t={middle}")):
        pixels, messages = browser.screenshot(page, tmp_path / f"{name}.png", fragment)
        assert messages == [], (name, messages)
        shots[name] = _canvas(html, pixels)
    area = shots["start"].shape[0] * shots["start"].shape[1]
    arms = _changed(shots["start"], shots["no robot"])
    assert arms.sum() > 0.03 * area  # both arms and the body fill a good part of the view
    arm_colours = shots["start"][arms]
    assert np.mean(np.ptp(arm_colours, axis=1) < 40) > 0.8  # the YuMi's greys
    cable = _changed(shots["start"], shots["no cable"])  # the tube and its shadow
    blue = shots["start"][..., 2] > shots["start"][..., 0] + 60
    assert (cable & blue).sum() > 300  # the cable's tube is seen, in its blue
    assert _tan(shots["no robot"]).sum() > 0.15 * area  # the table top
    moved = _changed(shots["start"], shots["middle"]) & (arms | _changed(
        shots["middle"], shots["no robot"]))
    assert moved.sum() > 0.01 * area  # the timeline moves the arms


@needs_chromium
@in_the_browser
@pytest.mark.parametrize("preset", ["ur5e_pair", "panda_pair"])
def test_the_pages_forward_kinematics_is_dloplans(tmp_path, preset, browser):
    """At every target's time the page's TCP (its scene graph at the interpolated joints) is
    where dloplan's FK puts it; a described cell's page draws its meshes, no capsule."""
    from dloplan.robot.urdf_cell import PRESETS

    program, arguments = _cell_plan(PRESETS[preset]())
    page = write_report(tmp_path / "report.html", title=preset, **arguments)
    text = page.read_text()
    assert f'"model":"{preset.split("_")[0]}"' in text and '"capsules":[]' in text
    robot = arguments["robot"]
    for k in (len(robot["times"]) // 2, len(robot["times"]) - 1):
        html, messages = browser.dom(page, f"t={robot['times'][k]}")
        assert messages == [] and "errors" not in body_data(html)
        drawn = np.array(json.loads(body_data(html)["tcp"]))
        expected = [_tcp(program, a, robot["joints"][a][k]) for a in range(2)]
        np.testing.assert_allclose(drawn, expected, atol=2e-5)  # page rounds to 1 micrometre
    pixels, messages = browser.screenshot(page, tmp_path / "shot.png")
    bare, _ = browser.screenshot(page, tmp_path / "bare.png", "hide=robot")
    assert messages == [] and _changed(pixels, bare).sum() > 20000  # the arms are drawn


@needs_chromium
@in_the_browser
def test_an_arm_of_another_description_is_drawn_as_its_capsules(tmp_path, browser):
    """An arm whose chain matches no model (here the UR5e's with the elbow 1 mm further out)
    gets its collision capsules and a parallel gripper, moved by the same scene graph."""
    from dloplan.robot.urdf_cell import ur5e_pair

    program, arguments = _cell_plan(ur5e_pair())
    robot = arguments["robot"]
    for arm in robot["arms"]:
        arm["joints"][2]["xyz"] = list(np.add(arm["joints"][2]["xyz"], [1e-3, 0.0, 0.0]))
    page = write_report(tmp_path / "report.html", title="other", **arguments)
    text = page.read_text()
    assert '"model":null' in text and '"meshes":{}' in text and '"generic_gripper":true' in text
    k = len(robot["times"]) - 1
    html, messages = browser.dom(page, f"t={robot['times'][k]}")
    assert messages == [] and "errors" not in body_data(html)
    expected = [scene_frames(robot["arms"][a], robot["joints"][a][k])[-1][:3, 3]
                for a in range(2)]
    np.testing.assert_allclose(json.loads(body_data(html)["tcp"]), expected, atol=2e-5)


@needs_chromium
@in_the_browser
def test_a_page_without_robot_plays_the_shapes(tmp_path, browser):
    """The study and compare reports: no arms, the timeline steps through the shapes (no dead
    motion button); the view still renders."""
    shapes, positions, rotations = small_plan()
    page = write_report(tmp_path / "report.html", title="shapes", shapes=shapes,
                        stabilized=shapes - [0, 0, 0.01], clip_positions=positions,
                        clip_rotations=rotations,
                        obstacles=[Box((0.3, 0.05, 0.02), (0.05, 0.05, 0.04)), Table(0.0)])
    html, messages = browser.dom(page, "t=2.5")
    data = body_data(html)
    assert messages == [] and data["rendered"] == "true" and float(data["time"]) == 2.5
    assert "shape 2 \u2192 3" in html  # the cable half way between shapes 2 and 3
    assert re.search(r'<label hidden="">\s*<input type="checkbox" data-layer="robot"', html)
    assert "Play motion" not in html
    html, messages = browser.dom(page, "play", seconds=1.5)  # Play plays
    assert messages == [] and float(body_data(html)["time"]) > 0 and "Pause" in html


@needs_chromium
def test_one_browser_reports_each_pages_console_and_leaves_no_process(tmp_path):
    """The browser the tests share: each page's console messages (a warning, an uncaught
    error) are its own, the next page starts with none, and closing ends every process; a
    browser opened and closed while another runs (a test's own beside the module's) leaves the
    test process the reaper of the other's processes; a page whose renderer crashes is an
    error at once and the browser goes on."""
    import subprocess

    def adopted() -> set[str]:  # Chromium's processes re-parented here (even as zombies)
        return set(subprocess.run(["pgrep", "-P", str(os.getpid()), "chrom"],
                                  capture_output=True, text=True).stdout.split())

    noisy, quiet = tmp_path / "noisy.html", tmp_path / "quiet.html"
    noisy.write_text("<html><body><script>console.warn('careful');"
                     "throw new Error('boom');</script></body></html>")
    quiet.write_text("<html><body data-ok='1'><p>fine</p></body></html>")
    reaper, others = is_subreaper(), adopted()  # others: the module's browser's, if it runs
    with Browser(tmp_path / "profile") as chromium:
        _, messages = chromium.dom(noisy)
        assert messages[0] == "console.warning: careful" and "Error: boom" in messages[1]
        html, messages = chromium.dom(quiet)
        assert messages == [] and body_data(html) == {"ok": "1"}
        with Browser(tmp_path / "inner") as inner:
            assert inner.dom(quiet)[1] == []
        assert is_subreaper()  # the outer browser's processes are still reaped here
        assert chromium.dom(quiet)[1] == []  # and it still serves pages
        with pytest.raises(RuntimeError, match="renderer crashed during Page.crash"):
            chromium.send("Page.crash", session=True)  # at once, not after the timeout
        assert chromium.dom(quiet)[1] == []  # the next page in a new renderer
        group = chromium.group
    left = subprocess.run(["pgrep", "-g", str(group)], capture_output=True, text=True).stdout
    assert left == "" and adopted() <= others and is_subreaper() == reaper
