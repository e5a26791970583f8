"""Plan a scenario and verify it on a robot cell from descriptions; write the vendor programs.

Until the scenario loader reads the proposed ``robot:`` section (docs/cells.md), this runner
removes it, plans the rest of the file with the application layer (``dloplan.app``), verifies
the plan's trajectory on the cell (:func:`dloplan.robot.urdf_cell.verify_on_cell`) and writes
into the output folder: the plan document (``plan.json``), the verdict rows
(``cell_verdict.json``), and per ``robot.programs`` the URScript programs
(:func:`dloplan.io.urscript.write_urscript`) and ROS 2 joint trajectories
(:func:`dloplan.io.ros_joints.write_joint_trajectories`).

Run: PYTHONPATH=src python examples/cells/run_cell.py examples/cells/ur5e_pair_usb.yaml -o out/ur5e
Exit code 0 when the cell verdict is ok, 3 when a check fails (programs are then not written).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import yaml

from dloplan.app.load import resolve_mapping
from dloplan.app.pipeline import run_job
from dloplan.app.writers import write_outputs
from dloplan.io.ros_joints import write_joint_trajectories
from dloplan.io.urscript import write_urscript
from dloplan.robot.urdf_cell import cell_from_mapping, verify_on_cell

FAILED = 3


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario")
    parser.add_argument("-o", "--out", default="out/cell")
    args = parser.parse_args(argv)
    path = Path(args.scenario)
    data = yaml.safe_load(path.read_text())
    robot = data.pop("robot", None)
    if not isinstance(robot, dict) or "cell" not in robot:
        raise ValueError(f"{path}: robot.cell: expected a cell section (docs/cells.md)")
    cell = cell_from_mapping(robot["cell"], path.parent)
    doc = run_job(resolve_mapping(data, str(path)), progress=print)
    out = Path(args.out)
    write_outputs(doc, out, ("json",))
    plan = verify_on_cell(cell, doc.trajectory, place=bool(robot.get("place", True)))
    verdict = plan.verdict
    print(f"cell {cell.name}: job shifted by {np.round(plan.offset, 3).tolist()} m"
          f"{', clips swapped' if plan.swapped else ''}; {verdict.message}")
    (out / "cell_verdict.json").write_text(json.dumps(
        {"cell": cell.name, "ok": verdict.ok, "message": verdict.message,
         "offset": plan.offset.tolist(), "rows": [row.to_dict() for row in verdict.rows]},
        indent=1))
    if not verdict.ok:
        print("no robot program written: a check fails", file=sys.stderr)
        return FAILED
    programs = robot.get("programs", ["ros_joints"])
    if "urscript" in programs:
        tcp = [np.concatenate([arm.tcp_offset, arm.tcp_rotation.as_rotvec()])
               for arm in cell.arms]
        positions, rotvecs = plan.base_poses()
        for path_out in write_urscript(out, plan.times, verdict.joints, tcp_positions=positions,
                                       tcp_rotvecs=rotvecs, tcp_offsets=tcp,
                                       **robot.get("urscript", {})):
            print(f"urscript: {path_out}")
    if "ros_joints" in programs:
        for path_out in write_joint_trajectories(out, plan.times, verdict.joints,
                                                 [arm.joint_names for arm in cell.arms],
                                                 **robot.get("ros_joints", {})):
            print(f"ros_joints: {path_out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
