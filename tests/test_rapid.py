"""The RAPID writer writes exactly the verified robot program.

Read-back: the robtargets, the start jointtarget, the tooldata and the wobjdata are read from
the written ``.mod`` files; the TCP pose of each robtarget (work object -> robot base, tool
from the file) is solved by IK seeded from the previous read-back solution with the arm angle
held at the file's ``eax_a``, and must give the verified joints back within 0.05 deg, their FK
the written position within 0.1 mm (the issue's bounds; the IK converges to 1e-5 m / 1e-5 rad,
and the 6-axis task with a held arm angle has isolated solutions, so the same branch gives
the same joints to ~1e-3 deg), and the same confdata.
"""

from __future__ import annotations

import os
import re

import numpy as np
import pytest
from program_readers import rapid_commands
from robot_plans import ON_ONE_WORKER, example_plan, harness_plan, read_module
from scipy.spatial.transform import Rotation

from dloplan import output_files as files
from dloplan.io.rapid import RapidSettings, rapid_modules, write_rapid
from dloplan.robot import Gripper, IKOptions, RobotCell, confdata, forward, inverse, yumi
from dloplan.robot import robot_program as make_program

# its module-scoped fixtures and the plans of robot_plans are computed once, on one worker (make
# test: --dist loadgroup)
pytestmark = ON_ONE_WORKER

PREDEFINED = {"v100", "fine"}  # controller data the modules use without declaring
CELL = RobotCell(base_position=(-0.03, 0.02, -0.01),
                 base_rotation=Rotation.from_euler("z", 4, degrees=True))


@pytest.fixture(scope="module", params=["m2_uniform_curvature_usb.yaml",
                                        "m1_sine_pu_hose.yaml", "harness"])
def program(request):
    if request.param == "harness":
        result = harness_plan()
        return make_program(result.grippers, result.trajectory, CELL)
    _, grippers, trajectory, _ = example_plan(request.param)
    return make_program(grippers, trajectory, CELL)


def test_read_back_robtargets_give_the_verified_joints(program, tmp_path):
    assert program.ok, program.message
    written = write_rapid(tmp_path, program)
    modules = {task: read_module(path.read_text()) for task, path in written.items()}
    for a, task in enumerate(("T_ROB_L", "T_ROB_R")):
        decl = modules[task]["declarations"]
        tool = decl[program.cell.tools[a].name][2]
        (_, tcp_rot), (_, uframe) = tool[1], decl[program.cell.wobj][2][3]
        tcp = Gripper(np.array(tool[1][0]) / 1e3, Rotation.from_quat(tcp_rot, scalar_first=True),
                      program.cell.tools[a].tcp_in_clip)
        arm = yumi(gripper=tcp).arms[a]  # the robot's base frame, tool from the file
        wobj_pos = np.array(decl[program.cell.wobj][2][3][0]) / 1e3
        wobj_rot = Rotation.from_quat(uframe, scalar_first=True)
        start = decl["dlo_start"][2]
        q = np.radians(np.r_[start[0][:2], start[1][0], start[0][2:]])  # ABB 1,2,7,3,4,5,6
        assert np.abs(np.degrees(q - program.joints[a][0])).max() < 1e-5
        names = sorted(n for n, d in decl.items() if d[1] == "robtarget")
        assert len(names) == program.n_targets
        for m, name in enumerate(names):
            trans, quat, conf, extax = decl[name][2]
            p = wobj_pos + wobj_rot.apply(np.array(trans) / 1e3)
            r = wobj_rot * Rotation.from_quat(quat, scalar_first=True)
            res = inverse(arm, p, r, seed=q, options=IKOptions(restarts=0),
                          arm_angle=np.radians(extax[0]))
            assert res.success, (task, name, res.message)
            q = res.q
            assert np.abs(np.degrees(q - program.joints[a][m])).max() < 0.05, (task, name)
            assert list(confdata(q)) == conf == list(program.targets.confdata[m, a])
            fk, _ = forward(arm, q)
            assert np.linalg.norm(fk - p) < 1e-4


def test_modules_declare_everything_they_use(program):
    modules = {t: read_module(x) for t, x in rapid_modules(program).items()}
    assert list(modules) == ["T_ROB_L", "T_ROB_R"]
    bodies = []
    for a, module in enumerate(modules.values()):
        decl, procs = module["declarations"], module["procs"]
        assert procs["main"] == ["dloplan_move;"]
        body = procs["dloplan_move"]
        assert body[:4] == ["ConfL \\On;", "g_GripOut;",
                            f"MoveAbsJ dlo_start, v100, fine, {program.cell.tools[a].name} "
                            f"\\WObj:={program.cell.wobj};", "SyncMoveOn dlo_sync_on, dlo_tasks;"]
        assert body[-1] == "SyncMoveOff dlo_sync_off;"
        # the gripper closes after reaching the grasp target and opens after the last shape,
        # with the default cycle's waits (the pipeline passes the plan's: test_program_actions)
        text = rapid_modules(program)[("T_ROB_L", "T_ROB_R")[a]]
        assert rapid_commands(text) == [(f"shape {0}", "close", 0.5),
                                        (f"shape {program.targets.release - program.targets.grasp}",
                                         "open",
                                         0.4)]
        used = set()
        for line in body:
            if line.startswith(("MoveL ", "MoveAbsJ ")):
                used |= set(re.findall(r"[A-Za-z_]\w*", line.split(" ", 1)[1])) - {"ID", "WObj",
                                                                                   "T"}
            if line.startswith(("SyncMoveOn", "SyncMoveOff", "WaitSyncTask")):
                used |= set(re.findall(r"[A-Za-z_]\w*", line.split(" ", 1)[1]))
        assert used - set(decl) <= PREDEFINED, used - set(decl)
        kinds = {name: typ for name, (_, typ, _) in decl.items()}
        assert kinds[program.cell.tools[a].name] == "tooldata"
        assert kinds[program.cell.wobj] == "wobjdata"
        assert kinds["dlo_sync_on"] == kinds["dlo_sync_off"] == "syncident"
        bodies.append([re.sub(r"\w+ \\WObj:=\w+;$", "", line) for line in body
                       if line.startswith("MoveL")])
        # speeds: the planned ones, per move and arm
        for m in range(1, program.n_targets):
            v_tcp, v_ori = decl[f"dlo_v{m:02d}"][2][:2]
            assert v_tcp == pytest.approx(1e3 * program.targets.speeds[m - 1, a, 0], abs=1e-6)
            assert v_ori == pytest.approx(np.degrees(program.targets.speeds[m - 1, a, 1]),
                                          abs=1e-6)
    ids = [[re.search(r"\\ID:=(\d+)", line).group(1) for line in body] for body in bodies]
    assert ids[0] == ids[1] and len(set(ids[0])) == len(ids[0])


def test_literals_agree_with_abb_motion_program_exec(program):
    """Independent cross-check of every data literal: the same numbers through
    abb_motion_program_exec's RAPID types (no independent RAPID *parser* is packaged; its
    writer is the second implementation), compared after reading both."""
    abb = pytest.importorskip("abb_motion_program_exec")
    from robot_plans import rapid_value

    modules = {t: read_module(x) for t, x in rapid_modules(program).items()}
    cell = program.cell
    for a, module in enumerate(modules.values()):
        decl = module["declarations"]
        tool = cell.tools[a]
        theirs = abb.tooldata(True, abb.pose(tool.tcp_offset * 1e3, [1, 0, 0, 0]),
                              abb.loaddata(tool.mass, tool.cog * 1e3, [1, 0, 0, 0],
                                           *tool.inertia))
        np.testing.assert_allclose(_flat(decl[tool.name][2]), _flat(rapid_value(
            theirs.to_rapid())), atol=1e-9)
        pos, rot = cell.wobj_frame
        wobj = abb.wobjdata(False, True, "", abb.pose(pos * 1e3, rot.as_quat(
            canonical=True, scalar_first=True)), abb.pose([0, 0, 0], [1, 0, 0, 0]))
        np.testing.assert_allclose(_flat(decl[cell.wobj][2]), _flat(rapid_value(
            wobj.to_rapid())), atol=1e-6)
        deg = np.degrees(program.joints[a][0])
        start = abb.jointtarget(deg[[0, 1, 3, 4, 5, 6]], [deg[2]] + [9e9] * 5)
        np.testing.assert_allclose(_flat(decl["dlo_start"][2]), _flat(rapid_value(
            start.to_rapid())), atol=1e-5)
        for m in range(program.n_targets):
            written = program.targets
            target = abb.robtarget(written.positions[m, a] * 1e3, written.quaternions[m, a],
                                   abb.confdata(*written.confdata[m, a]),
                                   [written.arm_angles[m, a]] + [9e9] * 5)
            np.testing.assert_allclose(_flat(decl[f"dlo_p{m:02d}"][2]), _flat(rapid_value(
                target.to_rapid())), atol=1e-5)


def _flat(value) -> list[float]:
    if isinstance(value, list):
        return [x for item in value for x in _flat(item)]
    return [] if isinstance(value, str) else [float(value)]


def test_a_failing_program_is_refused_unless_forced(tmp_path):
    _, grippers, trajectory, _ = example_plan("qualitative1_curved_pa12.yaml")
    failing = make_program(grippers, trajectory)
    assert not failing.ok
    with pytest.raises(ValueError, match="fails its checks: robot program FAILS: reach"):
        write_rapid(tmp_path / "rapid", failing)
    assert not (tmp_path / "rapid").exists()
    written = write_rapid(tmp_path / "rapid", failing, force=True)
    assert "robot program FAILS" in written["T_ROB_L"].read_text()


def test_settings_and_inputs_are_validated():
    with pytest.raises(ValueError, match=r"modules \(right\): got 'Dlo R'"):
        RapidSettings(modules=("DloL", "Dlo R"))
    with pytest.raises(ValueError, match="different task"):
        RapidSettings(tasks=("T_ROB_L", "T_ROB_L"))
    with pytest.raises(ValueError, match="procedure"):
        RapidSettings(procedure="main")
    with pytest.raises(ValueError, match="program: expected a RobotProgram"):
        rapid_modules(example_plan("m2_uniform_curvature_usb.yaml")[2])


def test_rapid_files_are_written_both_or_none(tmp_path, monkeypatch):
    _, grippers, trajectory, _ = example_plan("m2_uniform_curvature_usb.yaml")
    program = make_program(grippers, trajectory)
    folder = tmp_path / "rapid"
    folder.mkdir()
    (folder / "DloPlanL.mod").write_text("old left")
    calls = []

    def fsync_failing_second(fd):
        calls.append(fd)
        if len(calls) == 2:
            raise OSError("disk full")

    monkeypatch.setattr(files.os, "fsync", fsync_failing_second)
    with pytest.raises(OSError):
        write_rapid(folder, program)
    assert sorted(os.listdir(folder)) == ["DloPlanL.mod"]
    assert (folder / "DloPlanL.mod").read_text() == "old left"


@pytest.mark.parametrize("name", ["m1_sine_pu_hose.yaml", "m2_uniform_curvature_pa12.yaml",
                                  "m2_uniform_curvature_usb.yaml", "harness"])
def test_the_controller_reads_the_verified_joints_from_every_robtarget(name, tmp_path):
    """The written modules read as RobotWare reads them: each robtarget (pose in the work
    object, ``eax_a`` the arm angle, confdata) solved by the controller-semantics IK from no
    knowledge of the plan (the home pose, random seeds, every turn) has the verified joints
    among its solutions with that confdata, within 0.05 deg (the examples' own cells: the
    robot on the table); where another solution shares the confdata, the MoveL into the
    target ends on the verified one (the program's continuity row)."""
    from dloplan.robot.robtarget import ROUND_TRIP_TOLERANCE, solve_robtarget

    if name == "harness":
        result = harness_plan()
        grippers, trajectory, cell = result.grippers, result.trajectory, CELL
    else:
        _, grippers, trajectory, job = example_plan(name)
        cell = job.robot
    program = make_program(grippers, trajectory, cell)
    assert program.ok, program.message
    written = write_rapid(tmp_path, program)
    for a, task in enumerate(("T_ROB_L", "T_ROB_R")):
        decl = read_module(written[task].read_text())["declarations"]
        uframe = decl[cell.wobj][2][3]
        wobj_pos, wobj_rot = np.array(uframe[0]) / 1e3, Rotation.from_quat(uframe[1],
                                                                            scalar_first=True)
        arm = cell.robot.arms[a]  # placed in the plan's frame: the base frame back to it
        names = sorted(n for n, d in decl.items() if d[1] == "robtarget")
        for m, target in enumerate(names):
            trans, quat, conf, extax = decl[target][2]
            p_base = wobj_pos + wobj_rot.apply(np.array(trans) / 1e3)
            r_base = wobj_rot * Rotation.from_quat(quat, scalar_first=True)
            p = cell.base_rotation.apply(p_base) + cell.base_position
            r = cell.base_rotation * r_base
            found = solve_robtarget(arm, p, r.as_matrix(), np.radians(extax[0]), conf)
            assert found.deviation(program.joints[a][m]) <= ROUND_TRIP_TOLERANCE, (task, target)
            if not found.unique:
                assert all(r.ok for r in program.checks
                           if r.check == "continuity" and r.target == m), (task, target)
