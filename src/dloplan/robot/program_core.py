"""The core every robot program shares, whatever its cell.

A program (the YuMi's :class:`~dloplan.robot.program.RobotProgram`, a described cell's
:class:`~dloplan.robot.cell_program.CellProgram`) is a sequence of targets, the verified joints
of both arms at them, the joints along each move between them (the controller's motion,
sub-step by sub-step) timed by the plan's time law, and the verdict rows checked on exactly
that (:mod:`dloplan.robot.checks`). What differs from cell to cell is how the targets are
solved and written (the YuMi's arm-angle IK, confdata and RAPID; a described cell's tracked IK,
URScript, ur_rtde and ROS 2): that is each program's own. What does not differ is here, once:

- :class:`ProgramCore`: the verdict (``ok``, ``failures``), its summary per check and the
  one-line failure text, from the program's rows and its ``CHECKS`` order;
- :func:`speed_rows`: the ``joint speed`` row (and, where the arm publishes acceleration
  limits, the ``joint acceleration`` row) of every move and arm, from the peaks along the time
  law (:func:`~dloplan.robot.peaks.motion_peaks`);
- :func:`slowed`: a program over a joint speed limit re-timed, segment by segment, up to
  :data:`~dloplan.robot.checks.SLOW_ROUNDS` times (its targets and joints never change: only
  its timing, and the speed rows with it).
"""

from __future__ import annotations

import numpy as np

from .checks import SLOW_ROUNDS, CheckedProgram, CheckRow, check_summary
from .peaks import slowed_scale


class ProgramCore(CheckedProgram):
    """The verdict of a program from its ``checks`` in the order of its ``CHECKS``.

    A program also has ``trajectory`` (the timing it was verified with), ``record()`` (what
    :meth:`to_dict` writes of its targets), and for :func:`slowed` ``segment_speed_ratios()``
    (per segment of the trajectory the peak joint speed ratio of the moves it times) and
    ``retimed(trajectory)`` (the same targets and joints timed by another trajectory of the
    same path)."""

    CHECKS: tuple[str, ...] = ()

    def summary(self) -> list[dict]:
        """Per check: passed, the worst value and where, how many rows fail and the first."""
        return check_summary(self.checks, self.CHECKS)

    def failure_text(self, who=lambda arm: "" if arm == "both" else f"{arm} arm: ") -> str:
        """The first failing row of every failing check, in the order of ``CHECKS``:
        ``check at label (who value unit; note)`` joined by ``; `` (empty when none fails);
        ``who`` names a row's arm (``left``, ``right`` or ``both``)."""
        parts = []
        for name in self.CHECKS:
            first = next((r for r in self.checks if r.check == name and not r.ok), None)
            if first is not None:
                note = f"; {first.note}" if first.note else ""
                parts.append(f"{name} at {first.label} ({who(first.arm)}{first.value:.4g} "
                             f"{first.unit}{note})")
        return "; ".join(parts)

    def to_dict(self) -> dict:
        """JSON-ready: the verdict and its message, what the cell's program records of its
        targets (``record()``: the assignment, the targets as written, their joints), the
        summary and every check row."""
        return {"ok": self.ok, "message": self.message, **self.record(),
                "summary": self.summary(), "checks": [row.to_dict() for row in self.checks]}


def speed_rows(labels, shapes, arms, peaks, axis_name) -> tuple[CheckRow, ...]:
    """The rows along the time law: per move into target m = 1..M-1 and arm, ``joint speed``
    (the peak |dq/dt| over the joints as a fraction of the joint's limit) and, where the arm
    publishes acceleration limits, ``joint acceleration`` (the same for d2q/dt2).

    Parameters
    ----------
    labels : sequence of str
        (M,) the targets' labels.
    shapes : sequence of int
        (M,) the plan's shape each target belongs to.
    arms : sequence of CellArm
        The two arms (their ``name`` and ``max_acceleration``).
    peaks : sequence of JointPeaks
        Per arm the peaks of every move (:func:`~dloplan.robot.peaks.motion_peaks`).
    axis_name : callable
        Joint index (physical order) -> the axis' name in a note (``ABB axis 7``, ``joint 3``).
    """
    rows = []
    for m in range(1, len(labels)):
        j = m - 1
        for arm, p in zip(arms, peaks, strict=True):
            common = (m, labels[m], int(shapes[m]), arm.name)
            rows.append(CheckRow("joint speed", *common, float(p.speed[j]), "of the limit",
                                 bool(p.speed[j] <= 1.0),
                                 f"from {labels[m - 1]}; peak along the time law, "
                                 f"{axis_name(int(p.speed_joint[j]))}; peak joint acceleration "
                                 f"{p.largest_acceleration[j]:.3g} rad/s^2"))
            if np.isfinite(arm.max_acceleration).any():
                rows.append(CheckRow("joint acceleration", *common, float(p.acceleration[j]),
                                     "of the limit", bool(p.acceleration[j] <= 1.0),
                                     f"from {labels[m - 1]}; peak along the time law, "
                                     f"{axis_name(int(p.acceleration_joint[j]))}; "
                                     f"{p.largest_acceleration[j]:.3g} rad/s^2"))
    return tuple(rows)


def slowed(program):
    """``program`` re-timed while a move is over a joint speed limit: each such segment's speed
    scale of the time law (:func:`~dloplan.robot.peaks.slowed_scale`) brings it to
    :data:`~dloplan.robot.peaks.SLOW_MARGIN` of the limit, up to :data:`SLOW_ROUNDS` times
    (the last timing is kept whatever its verdict: its speed rows say what is left)."""
    for _ in range(SLOW_ROUNDS):
        ratios = program.segment_speed_ratios()
        if not np.any(ratios > 1.0):
            break
        timing = program.trajectory
        program = program.retimed(timing.with_speed_scale(slowed_scale(timing, ratios)))
    return program
