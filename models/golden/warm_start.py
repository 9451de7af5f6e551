"""Warm starting: each contact point starts a step from its accumulated impulse of the previous step, as Bullet 2 does.

Bullet's GPU solver zeroes every impulse at setup (``setConstraint4``). Bullet 2 keeps them: its persistent manifold
(``btPersistentManifold``, one per pair of collision objects) matches each new contact point to a cached one by the
point's position in body A's local frame (``getCacheEntry``: the nearest cached ``m_localPointA`` within the contact
breaking threshold, 0.02 m), the matched point inherits ``m_appliedImpulse`` (and the lateral ones), and
``btSequentialImpulseConstraintSolver::setupContactConstraint`` applies ``m_appliedImpulse * m_warmstartingFactor``
(0.85 by default) to the bodies before the first iteration.

Here, per step:

* :class:`ContactMemory` is what one step leaves for the next: per manifold its key (body A, body B: frame indices,
  each one pybullet (body, link)), its points in A's local frame, the accumulated normal impulse of each point and
  the manifold's friction impulse as a world vector (the two tangent impulses; the next step's tangents may differ).
* :func:`warm_start` matches this step's manifolds to the memory and returns the initial :class:`Impulses`
  (factor times the matched normal impulses, new points from zero; the friction vector projected on the new
  tangents, times the factor, clamped to the new friction limit ``mu * sum(normal)`` as the solver clamps it) and a
  :class:`WarmStartReport` that counts matched and new points and every dropped entry by its reason.
* :func:`apply_impulses` applies them on the host at constraint setup, ``v += M^-1 J^T lambda`` with the solver's
  signs and the frame's inverse inertia (float64, rounded once to the format), after which
  ``models.golden.contact_solver.solve(..., initial=...)`` starts each kind's first pass from them.

Matching deviates from Bullet in one point, stated: a cached point is inherited by at most one new point (nearest
pairs first), where Bullet's replace-in-slot lets a second match overwrite the first.

Bad input: a memory whose arrays disagree in count is rejected (``ValueError``); an entry with a NaN/Inf value or a
negative normal impulse is dropped and counted under its reason, as is a remembered point or manifold no longer in
the frame; initial impulses for :func:`apply_impulses` of the wrong shape or not finite are rejected.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from models.setup.constraints import BodyTable, ConstraintSet
from models.golden.contact_solver import Impulses
from models.setup.inertia import quat_to_matrix
from models.formats.number_format import Arithmetic

WARMSTART_FACTOR = 0.85  # btContactSolverInfo::m_warmstartingFactor
MATCH_THRESHOLD = 0.02  # m, Bullet's contact breaking threshold (gContactBreakingThreshold): getCacheEntry's radius

# the reasons an entry is dropped, as the report counts them
NONFINITE = "non-finite value"
NEGATIVE_NORMAL = "negative normal impulse"
POINT_GONE = "point no longer exists"
MANIFOLD_GONE = "manifold no longer exists"


@dataclass(frozen=True)
class Contacts:
    """The identity of this step's contact points: manifold keys and points in body A's local frame."""

    body_a: np.ndarray  # (M,) frame indices
    body_b: np.ndarray  # (M,)
    num_points: np.ndarray  # (M,)
    local_a: np.ndarray  # (M,4,3) m, unused points zero

    @staticmethod
    def of(body_a: np.ndarray, body_b: np.ndarray, num_points: np.ndarray, point_on_a: np.ndarray,
           bodies: BodyTable) -> "Contacts":
        """The contacts of a collision detection (world points on A) at the body poses it ran with."""
        a = np.asarray(body_a, dtype=np.int64)
        rot = quat_to_matrix(np.asarray(bodies.orientation[a], dtype=np.float64))  # (M,3,3) local -> world
        rel = np.asarray(point_on_a, dtype=np.float64) - np.asarray(bodies.position[a], dtype=np.float64)[:, None]
        local = np.einsum("mji,mkj->mki", rot, rel)  # R^T (p - x)
        valid = np.arange(4)[None, :] < np.asarray(num_points)[:, None]
        return Contacts(a, np.asarray(body_b, dtype=np.int64), np.asarray(num_points, dtype=np.int64),
                        np.where(valid[..., None], local, 0.0))

    @property
    def num_manifolds(self) -> int:
        return int(self.body_a.shape[0])

    def valid(self) -> np.ndarray:
        return np.arange(4)[None, :] < self.num_points[:, None]


@dataclass(frozen=True)
class ContactMemory:
    """What a step leaves for the next: its contacts and their accumulated impulses after the last pass."""

    contacts: Contacts
    normal: np.ndarray  # (M,4) N s per point
    friction_world: np.ndarray  # (M,3) N s, the friction impulse lambda_0 t_0 + lambda_1 t_1

    def __post_init__(self) -> None:
        m = self.contacts.num_manifolds
        shapes = {"body_b": self.contacts.body_b.shape, "num_points": self.contacts.num_points.shape,
                  "local_a": self.contacts.local_a.shape, "normal": self.normal.shape,
                  "friction_world": self.friction_world.shape}
        want = {"body_b": (m,), "num_points": (m,), "local_a": (m, 4, 3), "normal": (m, 4), "friction_world": (m, 3)}
        bad = [f"{k} {shapes[k]} (expected {want[k]})" for k in want if shapes[k] != want[k]]
        if bad:
            raise ValueError(f"warm-start memory of {m} manifolds does not match itself: {', '.join(bad)}")

    @staticmethod
    def of(contacts: Contacts, cons: ConstraintSet, impulses: Impulses) -> "ContactMemory":
        """This step's memory: ``impulses`` (the solve's accumulated ones) for the manifolds of ``cons``."""
        if impulses.normal.shape != (cons.num_manifolds, 4) or contacts.num_manifolds != cons.num_manifolds:
            raise ValueError(f"{impulses.normal.shape[0]} impulse rows and {contacts.num_manifolds} contacts for "
                             f"{cons.num_manifolds} manifolds")
        f = np.asarray(impulses.friction, dtype=np.float64)
        world = f[:, 0, None] * cons.tangent[:, 0] + f[:, 1, None] * cons.tangent[:, 1]
        return ContactMemory(contacts, np.asarray(impulses.normal, dtype=np.float64).copy(), world)


@dataclass
class WarmStartReport:
    """What one warm start did: points that inherited an impulse, points that start from zero, dropped entries."""

    matched_points: int = 0
    new_points: int = 0
    dropped: Counter = field(default_factory=Counter)  # reason -> count (points, or manifolds for MANIFOLD_GONE)

    def add(self, other: "WarmStartReport") -> None:
        self.matched_points += other.matched_points
        self.new_points += other.new_points
        self.dropped.update(other.dropped)

    def as_dict(self) -> dict[str, int]:
        return {"matched points": self.matched_points, "new points": self.new_points,
                **{f"dropped: {k}": int(v) for k, v in sorted(self.dropped.items())}}


@dataclass
class WarmStart:
    impulses: Impulses  # the initial impulses of the frame's manifolds (float64; round to the format to stream)
    report: WarmStartReport


def _usable(memory: ContactMemory, report: WarmStartReport) -> np.ndarray:
    """(M_old,4) remembered points that may be inherited; the others are counted as dropped by their reason."""
    valid = memory.contacts.valid()
    finite = (np.isfinite(memory.normal) & np.all(np.isfinite(memory.contacts.local_a), axis=2)
              & np.all(np.isfinite(memory.friction_world), axis=1)[:, None])
    negative = finite & (memory.normal < 0.0)
    report.dropped[NONFINITE] += int(np.count_nonzero(valid & ~finite))
    report.dropped[NEGATIVE_NORMAL] += int(np.count_nonzero(valid & negative))
    return valid & finite & ~negative


def _match_points(old_local: np.ndarray, old_ok: np.ndarray, new_local: np.ndarray, new_ok: np.ndarray,
                  threshold: float) -> np.ndarray:
    """(K,4) per new point the index of the old point it inherits (-1: none); nearest pairs first, each old point
    inherited once, only within ``threshold``."""
    d2 = np.sum((new_local[:, :, None, :] - old_local[:, None, :, :]) ** 2, axis=3)  # (K, new, old)
    d2 = np.where(new_ok[:, :, None] & old_ok[:, None, :] & (d2 < threshold * threshold), d2, np.inf)
    match = np.full(new_ok.shape, -1, dtype=np.int64)
    rows = np.arange(d2.shape[0])
    for _ in range(4):
        flat = np.argmin(d2.reshape(d2.shape[0], 16), axis=1)
        i, j = flat // 4, flat % 4
        hit = np.isfinite(d2[rows, i, j])
        match[rows[hit], i[hit]] = j[hit]
        d2[rows[hit], i[hit], :] = np.inf
        d2[rows[hit], :, j[hit]] = np.inf
    return match


def warm_start(memory: ContactMemory | None, contacts: Contacts, cons: ConstraintSet, friction_coeff: float,
               factor: float = WARMSTART_FACTOR, threshold: float = MATCH_THRESHOLD) -> WarmStart:
    """The initial impulses of this step's manifolds from the previous step's ``memory`` (zeros where none)."""
    m = cons.num_manifolds
    if contacts.num_manifolds != m:
        raise ValueError(f"{contacts.num_manifolds} contacts for {m} manifolds")
    out, report = Impulses.zeros(m), WarmStartReport()
    new_ok = contacts.valid()
    if memory is None:
        report.new_points = int(np.count_nonzero(new_ok))
        return WarmStart(out, report)
    old_ok = _usable(memory, report)
    index = {(a, b): r for r, (a, b) in enumerate(zip(memory.contacts.body_a.tolist(),
                                                      memory.contacts.body_b.tolist()))}
    old_row = np.array([index.get((a, b), -1) for a, b in zip(contacts.body_a.tolist(), contacts.body_b.tolist())],
                       dtype=np.int64).reshape(m)
    kept = np.flatnonzero(old_row >= 0)
    rows = old_row[kept]
    match = _match_points(memory.contacts.local_a[rows], old_ok[rows], contacts.local_a[kept], new_ok[kept],
                          threshold)
    hit = match >= 0
    inherited = np.take_along_axis(memory.normal[rows], np.maximum(match, 0), axis=1)
    out.normal[kept] = np.where(hit, factor * inherited, 0.0)
    carried = kept[np.any(hit, axis=1)]  # a manifold keeps its friction while any of its points persists
    f_world = memory.friction_world[old_row[carried]]
    mu = cons.friction[carried, 0] if cons.per_manifold_friction else np.full(carried.shape, friction_coeff)
    limit = mu * out.normal[carried].sum(axis=1)
    proj = factor * np.einsum("kd,kjd->kj", f_world, cons.tangent[carried])
    out.friction[carried] = np.clip(proj, -limit[:, None], limit[:, None])
    report.matched_points = int(np.count_nonzero(hit))
    report.new_points = int(np.count_nonzero(new_ok)) - report.matched_points
    used = np.zeros(old_ok.shape, dtype=bool)
    used[np.repeat(rows, 4)[hit.ravel()], match[hit]] = True
    gone = np.ones(memory.contacts.num_manifolds, dtype=bool)
    gone[rows] = False
    report.dropped[POINT_GONE] += int(np.count_nonzero(old_ok & ~used & ~gone[:, None]))
    report.dropped[MANIFOLD_GONE] += int(np.count_nonzero(gone))
    return WarmStart(out, report)


def check_impulses(initial: Impulses, cons: ConstraintSet) -> None:
    """Reject initial impulses that do not fit the frame: wrong count, NaN/Inf, a negative normal impulse."""
    m = cons.num_manifolds
    if initial.normal.shape != (m, 4) or initial.friction.shape != (m, 2):
        raise ValueError(f"initial impulses {initial.normal.shape} and {initial.friction.shape} for {m} manifolds "
                         f"(expected ({m}, 4) and ({m}, 2))")
    bad = ~np.isfinite(initial.normal).all(axis=1) | ~np.isfinite(initial.friction).all(axis=1)
    if np.any(bad):
        raise ValueError(f"initial impulses not finite in {int(np.count_nonzero(bad))} manifold(s), first "
                         f"{int(np.flatnonzero(bad)[0])}")
    if np.any(initial.normal < 0.0):
        raise ValueError(f"negative normal impulse in {int(np.count_nonzero(np.any(initial.normal < 0, axis=1)))} "
                         "manifold(s): the solver's accumulated normal impulse is clamped at 0")


def _inertia_times(inv_inertia: np.ndarray, c: np.ndarray) -> np.ndarray:
    """I^-1 c in float64 (diagonal (.,3) or symmetric (.,6) rows)."""
    if inv_inertia.shape[-1] == 3:
        return inv_inertia * c
    xx, yy, zz, xy, xz, yz = (inv_inertia[..., k] for k in range(6))
    cx, cy, cz = c[..., 0], c[..., 1], c[..., 2]
    return np.stack([xx * cx + xy * cy + xz * cz, xy * cx + yy * cy + yz * cz, xz * cx + yz * cy + zz * cz], axis=-1)


def apply_impulses(bodies: BodyTable, cons: ConstraintSet, initial: Impulses, ar: Arithmetic) -> BodyTable:
    """``v += M^-1 J^T lambda`` for the initial impulses, with the solver's signs (a normal impulse pushes A along
    +n at each point, a friction impulse acts along -t on A at the centre), float64 and rounded once to ``ar``.
    Static bodies are not written."""
    check_impulses(initial, cons)
    out = bodies.copy()
    a, b = cons.body_a, cons.body_b
    pts = np.asarray(cons.points, dtype=np.float64)
    n = np.asarray(cons.normal, dtype=np.float64)
    lam = np.where(cons.jac_inv != 0.0, initial.normal, 0.0)  # an unused point (jac_inv 0) carries nothing
    # per manifold: linear impulse on A and angular impulses (r x J) on A and B
    f_t = -(initial.friction[:, 0, None] * cons.tangent[:, 0] + initial.friction[:, 1, None] * cons.tangent[:, 1])
    lin = lam.sum(axis=1)[:, None] * n + f_t
    xa, xb = bodies.position[a], bodies.position[b]
    c = np.asarray(cons.center, dtype=np.float64)
    ang_a = np.sum(np.cross(pts - xa[:, None], n[:, None]) * lam[..., None], axis=1) + np.cross(c - xa, f_t)
    ang_b = np.sum(np.cross(pts - xb[:, None], n[:, None]) * lam[..., None], axis=1) + np.cross(c - xb, f_t)
    dv = np.zeros_like(bodies.linear_velocity, dtype=np.float64)
    dw = np.zeros_like(bodies.angular_velocity, dtype=np.float64)
    np.add.at(dv, a, bodies.inv_mass[a, None] * lin)
    np.add.at(dv, b, -bodies.inv_mass[b, None] * lin)
    np.add.at(dw, a, _inertia_times(bodies.inv_inertia[a], ang_a))
    np.add.at(dw, b, -_inertia_times(bodies.inv_inertia[b], ang_b))
    dyn = bodies.dynamic
    out.linear_velocity[dyn] = ar.round(bodies.linear_velocity[dyn] + dv[dyn])
    out.angular_velocity[dyn] = ar.round(bodies.angular_velocity[dyn] + dw[dyn])
    return out
