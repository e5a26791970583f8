"""The HTML report renders offline in a real browser (headless Chromium)."""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest
from matplotlib import image as mpimg

from dloplan.obstacles import Box, Table
from dloplan.plots.report import report_html, write_report

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--hide-scrollbars"]


def small_plan():
    s = np.linspace(0, 1, 11)
    shapes = np.stack([np.stack([0.1 + 0.4 * s, 0 * s + 0.1 * t, 0.1 + 0.05 * t * np.sin(
        np.pi * s)], 1) for t in np.linspace(0, 1, 5)])
    positions = shapes[:, [0, -1]]
    rotations = np.broadcast_to(np.eye(3), (5, 2, 3, 3))
    return shapes, positions, rotations


def test_report_is_self_contained(tmp_path):
    shapes, positions, rotations = small_plan()
    box = Box((0.3, 0, 0.02), (0.05, 0.05, 0.04))
    page = report_html(title="test", shapes=shapes, clip_positions=positions,
                       clip_rotations=rotations, obstacles=[box],
                       summary=["3 shapes"], warnings=["careful </script>"],
                       tables=[("t", ["a"], [[1]])])
    assert "http://" not in page and "https://" not in page  # no CDN, works offline
    assert page.count("<script") == 2
    assert "careful &lt;/script&gt;" in page
    with pytest.raises(ValueError, match="shapes"):
        report_html(title="x", shapes=np.zeros((3, 3)))


@pytest.mark.skipif(CHROMIUM is None, reason="Chromium is not installed (apt-get install chromium)")
def test_report_renders_in_headless_chromium(tmp_path):
    shapes, positions, rotations = small_plan()
    path = write_report(tmp_path / "report.html", title="render test", shapes=shapes,
                        stabilized=shapes - [0, 0, 0.01], clip_positions=positions,
                        clip_rotations=rotations,
                        obstacles=[Box((0.3, 0.05, 0.02), (0.05, 0.05, 0.04)), Table(0.0)])
    profile = tmp_path / "profile"
    common = [CHROMIUM, *FLAGS, f"--user-data-dir={profile}"]
    dom = subprocess.run([*common, "--dump-dom", path.as_uri()], capture_output=True, text=True,
                         timeout=120)
    assert 'data-rendered="true"' in dom.stdout, dom.stderr[-2000:]  # the script ran to its end
    shot = tmp_path / "shot.png"
    run = subprocess.run([*common, "--enable-logging=stderr", "--v=0", "--window-size=900,800",
                          f"--screenshot={shot}", path.as_uri()], capture_output=True, text=True,
                         timeout=120)
    assert shot.exists(), run.stderr[-2000:]
    assert "Uncaught" not in run.stderr
    pixels = mpimg.imread(shot)[60:560, 20:780, :3]  # the canvas area
    colours = np.unique((pixels * 255).astype(np.uint8).reshape(-1, 3), axis=0)
    assert len(colours) > 20  # not blank: lines in several colours and antialiasing
    blue = np.all(np.abs(pixels * 255 - [21, 101, 192]) < 40, axis=-1)
    assert blue.sum() > 50  # the planned cable is drawn


@pytest.mark.skipif(CHROMIUM is None, reason="Chromium is not installed (apt-get install chromium)")
def test_report_draws_both_arms_in_headless_chromium(tmp_path):
    from robot_plans import example_plan

    from dloplan.robot import robot_program

    shapes, grippers, trajectory, job = example_plan("m2_uniform_curvature_usb.yaml")
    program = robot_program(grippers, trajectory)
    common = dict(title="arms", shapes=shapes, clip_positions=grippers.positions,
                  clip_rotations=grippers.matrices, obstacles=list(job.obstacles) + [Table(0.0)])
    path = write_report(tmp_path / "report.html", **common, **program.report_arms())
    bare = write_report(tmp_path / "bare.html", **common)
    profile = tmp_path / "profile"
    shots = {}
    for name, page in (("arms", path), ("bare", bare)):
        shot = tmp_path / f"{name}.png"
        run = subprocess.run([CHROMIUM, *FLAGS, f"--user-data-dir={profile}",
                              "--enable-logging=stderr", "--v=0", "--window-size=900,800",
                              f"--screenshot={shot}", page.as_uri()], capture_output=True,
                             text=True, timeout=120)
        assert shot.exists() and "Uncaught" not in run.stderr, run.stderr[-2000:]
        shots[name] = (mpimg.imread(shot)[60:560, 20:780, :3] * 255).astype(int)
    dom = subprocess.run([CHROMIUM, *FLAGS, f"--user-data-dir={profile}", "--dump-dom",
                          path.as_uri()], capture_output=True, text=True, timeout=120).stdout
    assert 'data-rendered="true"' in dom and 'id="motion-controls"' in dom
    assert 'id="motion-controls" hidden' not in dom  # the time slider is shown

    def count(pixels, colour):
        return int(np.all(np.abs(pixels - colour) < 30, axis=-1).sum())

    for colour in ([142, 36, 170], [0, 137, 123]):  # left arm purple, right arm teal
        assert count(shots["arms"], colour) > 500  # each arm covers a visible area
        assert count(shots["bare"], colour) == 0  # ... which is not there without arms
    with pytest.raises(ValueError, match="arm_joints"):
        report_html(title="x", shapes=shapes, arm_joints=np.zeros((2, 2, 7)))
