"""A robot description's parse kept on disk (dloplan.robot.description_cache): what is read
from the cache is what parsing gives, and a changed URDF, argument or mesh file is parsed again.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from dloplan.robot import description_cache
from dloplan.robot.description import load_arm, parse_arm, vendored

pytest.importorskip("yourdfpy")

FIELDS = ("joint_names", "origin_xyz", "origin_rot", "axes", "lower", "upper", "max_velocity",
          "tip_xyz", "tip_rot", "capsules", "capsule_link", "radii", "base_link", "tip_link",
          "name", "source")

ARM = """<robot name="t">
  <link name="a"><collision><geometry><box size="0.1 0.4 0.2"/></geometry></collision></link>
  <link name="b"><collision><geometry><mesh filename="part.obj"/></geometry></collision></link>
  <link name="c"/>
  <joint name="j1" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 1 1"/>
    <limit lower="-1.0" upper="LIMIT" velocity="2.0" effort="1"/></joint>
  <joint name="f" type="fixed"><parent link="b"/><child link="c"/><origin xyz="0 0 0.5"/></joint>
</robot>"""


def _mesh(path, length: float) -> None:
    """A box-like mesh (OBJ) of ``length`` [m] along x: its capsule's length follows it."""
    corners = [(x, y, z) for x in (0.0, length) for y in (-0.02, 0.02) for z in (-0.02, 0.02)]
    path.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in corners)
                    + "f 1 2 3\nf 5 6 7\nf 1 5 2\n")


def _same(a, b) -> None:
    for name in FIELDS:
        x, y = getattr(a, name), getattr(b, name)
        if isinstance(x, np.ndarray):
            assert x.dtype == y.dtype and x.shape == y.shape, name
            np.testing.assert_array_equal(x, y, err_msg=name)
        else:
            assert x == y, name


@pytest.fixture
def folder(tmp_path, monkeypatch):
    """The cache in a fresh folder of the test's own."""
    cache = tmp_path / "cache"
    monkeypatch.setattr(description_cache, "FOLDER", cache)
    return cache


@pytest.mark.parametrize("urdf, tip, base", [("ur5e.urdf", "tool0", None),
                                             ("panda.urdf", "panda_hand", "panda_link0"),
                                             ("yumi.urdf", "yumi_link_7_l", "yumi_body")])
def test_a_kept_parse_is_the_parse_array_for_array(folder, urdf, tip, base):
    path = vendored(urdf)
    parsed = load_arm(path, tip, base_link=base)  # parsed, then kept
    assert len(list(folder.glob("*.npz"))) == 1
    kept = load_arm(path, tip, base_link=base)
    _same(parsed, kept)
    fields = parse_arm(path, path.read_text(), tip, base, {}, {})
    assert kept.joint_names == fields["joint_names"]
    named = load_arm(path, tip, base_link=base, name="other")  # the name is not part of it
    assert named.name == "other" and len(list(folder.glob("*.npz"))) == 1


def test_a_changed_urdf_or_argument_is_parsed_again(folder, tmp_path):
    urdf = tmp_path / "arm.urdf"
    _mesh(tmp_path / "part.obj", 0.3)
    urdf.write_text(ARM.replace("LIMIT", "1.0"))
    assert load_arm(urdf, "c").upper[0] == 1.0
    urdf.write_text(ARM.replace("LIMIT", "1.5"))  # the same path, another limit
    assert load_arm(urdf, "c").upper[0] == 1.5
    assert load_arm(urdf, "b").tip_link == "b"  # another tip link: its own entry
    assert len(list(folder.glob("*.npz"))) == 3


def test_a_changed_missing_or_new_mesh_is_read_again(folder, tmp_path):
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(ARM.replace("LIMIT", "1.0"))
    mesh = tmp_path / "part.obj"

    def capsules():
        """Link b's capsules as load_arm gives them, checked against a parse of the files."""
        arm = load_arm(urdf, "c")
        parsed = parse_arm(urdf, urdf.read_text(), "c", None, {}, {})
        np.testing.assert_array_equal(arm.capsules, parsed["capsules"])
        return arm.capsules[arm.capsule_link == 0]

    assert len(capsules()) == 0  # no mesh file: no capsule for link b
    _mesh(mesh, 0.3)
    short = capsules()  # the mesh appeared
    assert len(short) >= 1
    _mesh(mesh, 0.6)
    long = capsules()  # the mesh changed
    assert np.ptp(long[..., 0]) > np.ptp(short[..., 0]) + 0.2
    mesh.unlink()
    assert len(capsules()) == 0  # and went


def test_a_folder_that_cannot_be_written_costs_a_parse_not_an_error(tmp_path, monkeypatch):
    blocked = tmp_path / "file"
    blocked.write_text("not a folder")
    monkeypatch.setattr(description_cache, "FOLDER", blocked / "cache")
    arm = load_arm(vendored("ur5e.urdf"), "tool0")
    assert arm.n_joints == 6
    broken = tmp_path / "cache"  # an entry that cannot be read: parsed again
    monkeypatch.setattr(description_cache, "FOLDER", broken)
    load_arm(vendored("ur5e.urdf"), "tool0")
    for entry in broken.glob("*.npz"):
        entry.write_bytes(b"garbage")
    _same(load_arm(vendored("ur5e.urdf"), "tool0"), arm)


def test_at_most_max_entries_are_kept(tmp_path):
    for k in range(5):
        description_cache.save(f"{k:032x}", {"joint_names": ("j",), "base_link": "a",
                                             "tip_link": "b",
                                             **{n: np.zeros(1) for n in description_cache.ARRAYS}},
                               {}, folder=tmp_path)
    description_cache.prune(tmp_path, keep=3)
    assert len(list(tmp_path.glob("*.npz"))) == 3


def test_a_preset_cell_read_from_the_cache_does_not_import_the_urdf_reader():
    code = ("import sys; from dloplan.robot.urdf_cell import ur5e_pair, panda_pair; "
            "ur5e_pair(); panda_pair(); print('yourdfpy' in sys.modules)")
    subprocess.run([sys.executable, "-c", code], check=True)  # keeps the entries (if needed)
    done = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True,
                          text=True)
    assert done.stdout.strip() == "False"
