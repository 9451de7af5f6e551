"""Error of a solved step against a reference step: per-body velocity errors, summarised over the dynamic bodies.

Per dynamic body, ``|dv|`` is the Euclidean norm of the linear velocity difference (m/s) and ``|dw|`` that of the
angular velocity difference (rad/s). Reported: their maximum, median and 99th percentile over the dynamic bodies,
and the maxima relative to the reference's largest body speed ``max |v_ref|`` and largest angular speed
``max |w_ref|`` (dimensionless).
"""

from __future__ import annotations

import numpy as np

from .constraints import BodyTable


def solution_error(ours: BodyTable, ref: BodyTable, dynamic: np.ndarray) -> dict[str, float]:
    """Max, median and p99 of |dv| (m/s) and |dw| (rad/s) over the dynamic bodies, and the relative maxima."""
    dv = np.linalg.norm(ours.linear_velocity[dynamic] - ref.linear_velocity[dynamic], axis=1)
    dw = np.linalg.norm(ours.angular_velocity[dynamic] - ref.angular_velocity[dynamic], axis=1)
    v_scale = float(np.linalg.norm(ref.linear_velocity[dynamic], axis=1).max(initial=0.0))
    w_scale = float(np.linalg.norm(ref.angular_velocity[dynamic], axis=1).max(initial=0.0))
    out: dict[str, float] = {}
    for name, unit, err, scale in (("|dv|", "m/s", dv, v_scale), ("|dw|", "rad/s", dw, w_scale)):
        out[f"max {name} ({unit})"] = float(err.max(initial=0.0))
        out[f"median {name} ({unit})"] = float(np.median(err)) if err.size else 0.0
        out[f"p99 {name} ({unit})"] = float(np.percentile(err, 99)) if err.size else 0.0
        ref_name = "|v_ref|" if name == "|dv|" else "|w_ref|"
        out[f"max {name} / max {ref_name}"] = float(err.max(initial=0.0)) / scale if scale > 0 else 0.0
    return out
