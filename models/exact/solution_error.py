"""Error of a solved step against a reference step: per-body velocity errors, summarised over the dynamic bodies.

Per dynamic body, ``|dv|`` is the Euclidean norm of the linear velocity difference (m/s) and ``|dw|`` that of the
angular velocity difference (rad/s). Reported (:class:`SolutionError`): their maximum, median and 99th percentile
over the dynamic bodies, and the maxima relative to the reference's largest body speed ``max |v_ref|`` and largest
angular speed ``max |w_ref|`` (dimensionless).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models.setup.constraints import BodyTable


@dataclass(frozen=True)
class SolutionError:
    """Per-body |dv| (m/s) and |dw| (rad/s) over the dynamic bodies, and the maxima over the reference's speeds."""

    max_dv: float
    median_dv: float
    p99_dv: float
    max_dw: float
    median_dw: float
    p99_dw: float
    relative_dv: float  # max |dv| / max |v_ref| (0 when the reference is at rest)
    relative_dw: float  # max |dw| / max |w_ref|


def solution_error(ours: BodyTable, ref: BodyTable, dynamic: np.ndarray) -> SolutionError:
    """Max, median and p99 of |dv| (m/s) and |dw| (rad/s) over the dynamic bodies, and the relative maxima."""
    dv = np.linalg.norm(ours.linear_velocity[dynamic] - ref.linear_velocity[dynamic], axis=1)
    dw = np.linalg.norm(ours.angular_velocity[dynamic] - ref.angular_velocity[dynamic], axis=1)
    v_scale = float(np.linalg.norm(ref.linear_velocity[dynamic], axis=1).max(initial=0.0))
    w_scale = float(np.linalg.norm(ref.angular_velocity[dynamic], axis=1).max(initial=0.0))
    return SolutionError(*_summary(dv), *_summary(dw), _relative(dv, v_scale), _relative(dw, w_scale))


def _summary(err: np.ndarray) -> tuple[float, float, float]:
    if not err.size:
        return 0.0, 0.0, 0.0
    return float(err.max()), float(np.median(err)), float(np.percentile(err, 99))


def _relative(err: np.ndarray, scale: float) -> float:
    return float(err.max(initial=0.0)) / scale if scale > 0 else 0.0
