"""The contest mission judged against ground truth (the app layer's business only).

The mission node says what it believes (pads landed, score so far); this module says
what happened: where the vehicle really touched down on each landing, whether that is
inside the pad (the contest's rule for a valid landing), the score those landings earn
with the robot's true points table, the distance flown and the tracking RMSE per axis
(setpoint against flown, seed 003 Tables 4-5).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from quadmission.evaluation.tracking import FloatArray, rounded
from sim.arena import PAD_SIZE, ArenaSpec
from sim.world import Trajectory


@dataclass(frozen=True)
class Landing:
    """One touchdown the mission reported on a sequence pad, with the truth at that time."""

    pad: int
    t_s: float
    touchdown_xy: tuple[float, float] | None  # m, true position; None past the truth
    error_m: float | None  # m, horizontal distance to the pad's centre
    inside: bool  # the touchdown point lies on the 1 m pad

    def to_json(self) -> dict[str, Any]:
        return {"pad": self.pad, "t_s": rounded(self.t_s, 2),
                "touchdown_xy_m": None if self.touchdown_xy is None
                else [rounded(v) for v in self.touchdown_xy],
                "touchdown_error_m": rounded(self.error_m), "inside_pad": self.inside}


def truth_at(truth: Trajectory, t_s: float) -> FloatArray | None:
    """The true position [m] at ``t_s`` (the first sample at or after it), None past the
    end of the recording."""
    if not len(truth) or t_s > truth.t[-1]:
        return None
    i = int(np.searchsorted(truth.t, t_s))
    return np.asarray(truth.position[i], dtype=np.float64)


def landing(arena: ArenaSpec, pad_id: int, t_s: float, truth: Trajectory) -> Landing:
    """Judge the touchdown on ``pad_id`` reported at ``t_s`` (when the vehicle is down)."""
    cx, cy = arena.pad(pad_id).center
    p = truth_at(truth, t_s)
    if p is None:
        return Landing(pad_id, t_s, None, None, False)
    dx, dy = float(p[0]) - cx, float(p[1]) - cy
    inside = abs(dx) <= PAD_SIZE / 2.0 and abs(dy) <= PAD_SIZE / 2.0
    return Landing(pad_id, t_s, (float(p[0]), float(p[1])), math.hypot(dx, dy), inside)


def score(landings: Sequence[Landing], table: Mapping[int, int]) -> int:
    """Points earned: every pad landed inside once, at the robot's true table."""
    return sum(table.get(pad, 0) for pad in {d.pad for d in landings if d.inside})


def distance_m(truth: Trajectory, window: tuple[float, float]) -> float:
    """Length of the true 3-D path flown in ``window`` [s]."""
    keep = (truth.t >= window[0]) & (truth.t <= window[1])
    p = truth.position[keep]
    return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum()) if len(p) > 1 else 0.0


def touchdown_summary(landings: Sequence[Landing]) -> dict[str, Any]:
    """RMSE and max of the touchdown errors, as in the precision-landing report."""
    errors = [d.error_m for d in landings if d.error_m is not None]
    return {"touchdown_rmse_m": rounded(float(np.sqrt(np.mean(np.square(errors)))))
            if errors else None,
            "touchdown_max_m": rounded(max(errors)) if errors else None,
            "all_inside": bool(landings) and all(d.inside for d in landings)}


__all__ = ["Landing", "distance_m", "landing", "score", "touchdown_summary", "truth_at"]
