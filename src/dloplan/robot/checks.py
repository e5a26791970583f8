"""The verdict table every robot program carries, whatever its cell: one :class:`CheckRow` per
check, target and arm, and their summary (:func:`check_summary`), the verdict of the one
robot program (:class:`~dloplan.robot.program.RobotProgram`); the path check of a described
cell (:func:`~dloplan.robot.path.check_path`) writes its rows.
"""

from __future__ import annotations

from dataclasses import dataclass

SLOW_ROUNDS = 3
"""Times a program over a joint-speed limit is slowed (re-timed) before it is refused."""

LOWER_IS_WORSE = frozenset({"assignment", "joint limits", "clearance", "table clearance"})
"""Checks whose worst row is the lowest value (a separation, margin or clearance); of the others
the highest (an error, a joint step, a ratio to a limit)."""


@dataclass(frozen=True)
class CheckRow:
    """One line of the verdict table.

    Attributes
    ----------
    check : str
        The check's name (one of the program's ``CHECKS``).
    target : int or None
        Index of the program target (None for a per-shape assignment row).
    label : str
        ``"approach"``, ``"shape k"`` or ``"retreat"``.
    shape : int
        The plan's shape index the target belongs to (approach: 0, retreat: the last).
    arm : str
        ``"left"``, ``"right"`` or ``"both"``.
    value : float
        The checked quantity, in ``unit``.
    unit : str
    ok : bool
    note : str
        What it means when not obvious (closest links, joint that limits, ...).
    """

    check: str
    target: int | None
    label: str
    shape: int
    arm: str
    value: float
    unit: str
    ok: bool
    note: str = ""

    def to_dict(self) -> dict:
        """JSON-ready."""
        return {"check": self.check, "target": self.target, "label": self.label,
                "shape": self.shape, "arm": self.arm, "value": float(self.value),
                "unit": self.unit, "ok": bool(self.ok), "note": self.note}


def check_summary(rows, checks) -> list[dict]:
    """Per check of ``checks`` (in that order) with rows: ``check``, ``ok``, ``failures``,
    ``worst`` (the lowest value for a check in :data:`LOWER_IS_WORSE`, else the highest) with its
    ``unit`` and ``where``, and the label of the ``first_failure`` (or None)."""
    lines = []
    for name in checks:
        mine = [r for r in rows if r.check == name]
        if not mine:
            continue
        pick = min if name in LOWER_IS_WORSE else max
        worst = pick(mine, key=lambda r: r.value)
        failed = [r for r in mine if not r.ok]
        lines.append({"check": name, "ok": not failed, "failures": len(failed),
                      "worst": float(worst.value), "unit": worst.unit,
                      "where": f"{worst.label}, {worst.arm}" + (
                          f" ({worst.note})" if worst.note else ""),
                      "first_failure": failed[0].label if failed else None})
    return lines
