"""The verification table: rows, optional checks, verdict, JSON form."""

import json
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dloplan.cable import catalogue_cable
from dloplan.sim.clips import ClipPoses
from dloplan.sim.statics import continuation
from dloplan.verify.report import Reachability, verify_path

# its module-scoped fixtures are computed once, on one worker (make test: --dist loadgroup)
pytestmark = pytest.mark.xdist_group("test_verify_report")

CABLE = catalogue_cable("usb", 8).with_modulus(2.5e5)
FACING = Rotation.from_rotvec([[0, 0, 0], [0, 0, math.pi]])
POSES = [ClipPoses(np.array([[0, 0, 0.3], [0.4 - dx, dx, 0.3]]), FACING) for dx in (0, 0.04, 0.08)]


@pytest.fixture(scope="module")
def shapes():
    guess = np.zeros((9, 3))
    guess[:, 0] = np.linspace(-0.05, 0.45, 9)
    return np.stack([e.shape for e in continuation(CABLE, guess, POSES, substeps=5)])


def test_full_table_with_reachability_and_replay(shapes):
    reach = [Reachability(True, True, 0.4), {"reachable_left": True, "reachable_right": False,
                                             "joint_margin": 0.0, "message": "joint 4"},
             Reachability(True, True, 0.2)]
    result = verify_path(CABLE, shapes, POSES, times=[0.0, 1.5, 3.0], reachability=reach)
    assert len(result.rows) == 3
    assert all(r.stable for r in result.rows)
    assert result.rows[0].snap is None and result.rows[1].snap is False
    assert result.rows[1].reachable_right is False and result.rows[1].joint_margin == 0.0
    assert all(r.replay_deviation is not None for r in result.rows)
    assert not result.ok  # the right arm cannot reach shape 1
    assert any("right arm" in m and "joint 4" in m for m in result.messages)
    assert set(result.timings) == {"stability", "snap", "replay"}
    text = result.table()
    assert len(text.splitlines()) == 5 and "FAILED" in text
    data = json.loads(json.dumps(result.to_dict()))
    assert data["ok"] is False and data["rows"][1]["reachable_right"] is False
    assert data["rows"][0]["snap"] is None


def test_minimal_table_passes_and_leaves_unchecked_columns_empty(shapes):
    result = verify_path(CABLE, shapes, POSES)
    assert result.ok and result.replay is None
    row = result.rows[2]
    assert row.reachable_left is None and row.replay_deviation is None
    assert row.smallest_eigenvalue > 0 and row.straying is not None
    assert "verdict: ok" in result.table()
    assert set(result.timings) == {"stability", "snap"}


def test_unstable_shape_fails_the_plan():
    # a weightless straight column whose clips are 10 % closer than its length: past buckling
    cable = catalogue_cable("usb", 10)
    clips = ClipPoses(np.array([[0, 0, 0], [0.9 * 0.45, 0, 0]]), FACING)
    held = clips.held_points(cable.rest_link_length)
    x = np.zeros((11, 3))
    x[[0, -1]] = held[[0, 3]]
    x[1:-1, 0] = np.linspace(held[1, 0], held[2, 0], 9)
    result = verify_path(cable, x[None], gravity=(0, 0, 0), snap=False)
    assert not result.ok and not result.rows[0].stable
    assert result.rows[0].smallest_eigenvalue < 0
    assert "shape 0: not stable" in result.messages[0]


def test_bad_inputs(shapes):
    with pytest.raises(ValueError, match="reachability"):
        verify_path(CABLE, shapes, POSES, reachability=[Reachability(True, True)])
    with pytest.raises(ValueError, match="reachability"):
        verify_path(CABLE, shapes, POSES, reachability=[{"left": True}] * 3)
    with pytest.raises(ValueError, match="times"):
        verify_path(CABLE, shapes, POSES, trajectory=([0, 1, 2], POSES))
    with pytest.raises(ValueError, match="times"):
        verify_path(CABLE, shapes, POSES, times=[0, 1])
