"""Substeps: a step of ``dt`` solved and integrated as ``n`` kernel calls of ``dt / n`` on one collision detection.

Box2D v3's soft step (``b2SolverStage``: substeps with the contact bias recomputed from the current separation, warm
starting across substeps) without its spring-damper mass and impulse scales (those, with the kernel's one added
multiply, are ``models/golden/soft_contact.py``): here the host only sets, per call, what the kernel already reads, so
no RTL change is needed:

* the time step of the call (``IntegrationParams.dt`` = dt / n: the kernel integrates positions and adds g dt / n),
* each point's bias from its separation *now*, Bullet's ``(d + positionDrift) * positionCoeff / (dt / n)``, where
  ``d = n . (p_A - p_B)`` follows both contact points with their bodies from the collision detection's poses
  (Box2D's ``relativeAnchor`` separation update; the normal, the points the kernel reads and the effective masses
  stay those of the collision detection, as in Box2D's substeps),
* the initial impulses: the previous substep's accumulated ones in full (Box2D's warm start between substeps),
  applied on the host (``models.golden.warm_start.apply_impulses``).

Each substep runs the kernel's full pass sequence: its manifold-passes per step are ``n`` times the call's.

Relax (``Remedy.relax``): the last substep runs with the position correction removed from the bias (Box2D's relax
iterations, which run after the position update; here the last call solves and integrates, so it is a relax
*substep*). The velocities the step ends with, and the impulses the next step is warm-started from, then hold no
Baumgarte push: with Bullet's bias in every call, a warm start carries last step's push-apart impulse into the next
step and the contacts overshoot.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from models.setup.constraints import POSITION_COEFF, POSITION_DRIFT, BodyTable, ConstraintSet
from models.setup.inertia import quat_to_matrix
from models.formats.number_format import Arithmetic


@dataclass(frozen=True)
class ContactPoints:
    """The collision detection's points in world space, with the body poses it ran at."""

    body_a: np.ndarray  # (M,)
    body_b: np.ndarray  # (M,)
    valid: np.ndarray  # (M,4) bool
    normal: np.ndarray  # (M,3) from B to A
    point_on_a: np.ndarray  # (M,4,3) m
    point_on_b: np.ndarray  # (M,4,3) m
    position: np.ndarray  # (N,3) the bodies' positions at the detection
    orientation: np.ndarray  # (N,4)

    def separation(self, bodies: BodyTable) -> np.ndarray:
        """(M,4) each point's separation ``n . (p_A - p_B)`` at the poses of ``bodies``, the points moved rigidly with
        their bodies from the detection's poses (negative: penetration)."""
        pa = _moved(self.point_on_a, self.body_a, self.position, self.orientation, bodies)
        pb = _moved(self.point_on_b, self.body_b, self.position, self.orientation, bodies)
        return np.einsum("mkd,md->mk", pa - pb, self.normal)


def _moved(points: np.ndarray, idx: np.ndarray, x0: np.ndarray, q0: np.ndarray, bodies: BodyTable) -> np.ndarray:
    """World points fixed in bodies ``idx``, moved from poses (x0, q0) to the poses of ``bodies``."""
    r0 = quat_to_matrix(np.asarray(q0[idx], dtype=np.float64))
    r1 = quat_to_matrix(np.asarray(bodies.orientation[idx], dtype=np.float64))
    local = np.einsum("mji,mkj->mki", r0, points - x0[idx][:, None])
    return np.asarray(bodies.position[idx], dtype=np.float64)[:, None] + np.einsum("mij,mkj->mki", r1, local)


def substep_constraints(cons: ConstraintSet, contacts: ContactPoints, bodies: BodyTable, dt: float,
                        ar: Arithmetic, relax: bool = False) -> ConstraintSet:
    """``cons`` with each valid point's bias from its separation at ``bodies``' poses for a call of ``dt``,
    rounded to the format (every other field as set up). ``relax``: the position correction removed (a negative
    bias, which pushes a contact deeper than the slop apart, becomes 0; a positive one, which lets a contact close
    its gap, stays), Box2D's relax iterations."""
    d = contacts.separation(bodies)
    bias = np.where(contacts.valid, (d + POSITION_DRIFT) * POSITION_COEFF / dt, 0.0)
    if relax:
        bias = np.maximum(bias, 0.0)
    return replace(cons, bias=ar.round(bias))
