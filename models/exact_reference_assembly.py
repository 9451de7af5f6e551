"""Assembly of the exact reference's problems (``models/exact_reference.py``): the rows of each phase over the
dynamic bodies' velocities (6 columns per body: v then w), the spin rows of the damped manifolds, and the islands
(bodies connected through manifolds between dynamic bodies: independent problems)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from .constraints import BodyTable, ConstraintSet

EIGEN_TOLERANCE = 1e-9  # relative: n is an eigenvector of the inverse inertia
SPAN_TOLERANCE = 1e-6  # relative singular value below which a body's damped normals add no spin row


class ExactReferenceError(RuntimeError):
    """No exact reference for this problem: the reason is the message."""



# --- assembly -------------------------------------------------------------------------------------------------
@dataclass
class Rows:
    """Sparse rows J (over the dynamic bodies' 6 velocity columns each) and the constant c: value = J u + c."""

    J: sp.csr_matrix
    c: np.ndarray
    body_a: np.ndarray  # (R,) frame body index of each row's A and B (island assignment)
    body_b: np.ndarray


class Layout:
    """Column layout: dynamic body k owns columns 6k..6k+2 (v) and 6k+3..6k+5 (w)."""

    def __init__(self, bodies: BodyTable):
        self.bodies = bodies
        self.dynamic = bodies.dynamic
        self.index = np.full(bodies.num_bodies, -1, dtype=np.int64)
        self.index[self.dynamic] = np.arange(int(self.dynamic.sum()))
        self.n = int(self.dynamic.sum())
        if bodies.inv_inertia.shape[1] != 3:
            raise ExactReferenceError(
                f"the body table carries the full symmetric inverse inertia ({bodies.inv_inertia.shape[1]} words per "
                "body, rotated non-cube bodies): the exact reference's QPs take a diagonal M only, and the damped "
                "spin row is then no convex program (models/exact_reference.py)")
        inv = np.concatenate([np.repeat(bodies.inv_mass[self.dynamic, None], 3, axis=1),
                              bodies.inv_inertia[self.dynamic]], axis=1)
        if np.any(~(inv > 0)) or not np.all(np.isfinite(inv)):
            raise ExactReferenceError("a dynamic body has a non-positive or non-finite inverse mass or inertia")
        self.inv_m = inv.ravel()  # diag(M^-1), (6n,)

    def velocity(self, bodies: BodyTable) -> np.ndarray:
        return np.concatenate([bodies.linear_velocity[self.dynamic], bodies.angular_velocity[self.dynamic]],
                              axis=1).ravel()

    def with_velocity(self, bodies: BodyTable, u: np.ndarray) -> BodyTable:
        out = bodies.copy()
        uu = u.reshape(-1, 6)
        out.linear_velocity[self.dynamic] = uu[:, :3]
        out.angular_velocity[self.dynamic] = uu[:, 3:]
        return out


def assemble_rows(layout: Layout, a: np.ndarray, b: np.ndarray, lin: np.ndarray, ang_a: np.ndarray, ang_b: np.ndarray,
          const: np.ndarray) -> Rows:
    """Rows ``(lin.vA - lin.vB) + (ang_a.wA - ang_b.wB) + const``; static bodies' terms go into the constant."""
    bodies = layout.bodies
    r = a.shape[0]
    c = const.astype(np.float64).copy()
    rows, cols, vals = [], [], []
    for body, sign, ang in ((a, 1.0, ang_a), (b, -1.0, ang_b)):
        dyn = layout.dynamic[body]
        stat = ~dyn
        c[stat] += sign * (np.sum(lin[stat] * bodies.linear_velocity[body[stat]], axis=1)
                           + np.sum(ang[stat] * bodies.angular_velocity[body[stat]], axis=1))
        idx = np.flatnonzero(dyn)
        base = 6 * layout.index[body[idx]]
        coef = sign * np.concatenate([lin[idx], ang[idx]], axis=1)  # (k,6)
        rows.append(np.repeat(idx, 6))
        cols.append((base[:, None] + np.arange(6)[None, :]).ravel())
        vals.append(coef.ravel())
    J = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(r, 6 * layout.n))
    return Rows(J, c, a, b)


def contact_rows(layout: Layout, cons: ConstraintSet) -> tuple[Rows, np.ndarray]:
    """One row per active contact point (manifold-major, point order); returns the rows and their (m, i) mask."""
    active = cons.jac_inv != 0.0
    m, _ = np.nonzero(active)
    n = cons.normal[m]
    p = cons.points[active]
    pos = layout.bodies.position
    ca = np.cross(p - pos[cons.body_a[m]], n)
    cb = np.cross(p - pos[cons.body_b[m]], n)
    return assemble_rows(layout, cons.body_a[m], cons.body_b[m], n, ca, cb, cons.bias[active]), active


def friction_rows(layout: Layout, cons: ConstraintSet, manifolds: np.ndarray) -> Rows:
    """Rows (m, j) for j = 0, 1 of the given manifolds, manifold-major: the tangent velocity the pass reads."""
    m = np.repeat(manifolds, 2)
    j = np.tile([0, 1], manifolds.shape[0])
    t = cons.tangent[m, j]
    pos = layout.bodies.position
    ca = np.cross(cons.center[m] - pos[cons.body_a[m]], t)
    cb = np.cross(cons.center[m] - pos[cons.body_b[m]], t)
    return assemble_rows(layout, cons.body_a[m], cons.body_b[m], t, ca, cb, np.zeros(m.shape[0]))


def spin_rows(layout: Layout, cons: ConstraintSet, damped: np.ndarray) -> tuple[sp.csr_matrix, np.ndarray]:
    """Rows n.w_k = 0 for each damped manifold's dynamic bodies (duplicates removed); also their body indices."""
    pairs = []
    for side in (cons.body_a, cons.body_b):
        body = side[damped]
        keep = layout.dynamic[body]
        pairs.append((body[keep], cons.normal[damped][keep]))
    body = np.concatenate([p[0] for p in pairs])
    n = np.concatenate([p[1] for p in pairs])
    _check_spin_rows_are_a_qp(layout.bodies, body, n)
    body, n = _span_basis(body, n)
    cols = 6 * layout.index[body][:, None] + 3 + np.arange(3)[None, :]
    rows = np.repeat(np.arange(body.shape[0]), 3)
    N = sp.csr_matrix((n.ravel(), (rows, cols.ravel())), shape=(body.shape[0], 6 * layout.n))
    return N, body


def _span_basis(body: np.ndarray, n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per body, an orthonormal basis of the span of its damped normals (w orthogonal to every n_k is w
    orthogonal to their span); directions below SPAN_TOLERANCE of the largest singular value are dropped, so
    normals equal up to rounding give one row instead of a singular set."""
    if not body.size:
        return body, n
    order = np.argsort(body, kind="stable")
    body, n = body[order], n[order]
    starts = np.flatnonzero(np.r_[True, body[1:] != body[:-1]])
    out_b, out_n = [], []
    for lo, hi in zip(starts, np.r_[starts[1:], body.size]):
        _, sv, vt = np.linalg.svd(n[lo:hi], full_matrices=False)
        keep = sv > SPAN_TOLERANCE * sv[0]
        out_n.append(vt[keep])
        out_b.append(np.full(int(keep.sum()), body[lo]))
    return np.concatenate(out_b), np.concatenate(out_n)


def _check_spin_rows_are_a_qp(bodies: BodyTable, body: np.ndarray, n: np.ndarray) -> None:
    if not body.size:
        return
    iin = bodies.inv_inertia[body] * n
    along = np.sum(iin * n, axis=1)[:, None] * n
    off = np.linalg.norm(iin - along, axis=1) / np.maximum(np.linalg.norm(iin, axis=1), 1e-300)
    worst = int(np.argmax(off))
    if off[worst] > EIGEN_TOLERANCE:
        raise ExactReferenceError(
            f"spin damping on body {int(body[worst])}: the normal {n[worst].round(6).tolist()} is not an "
            f"eigenvector of its inverse inertia {bodies.inv_inertia[body[worst]].tolist()} (relative "
            f"{off[worst]:.1e}): the damped friction phase is no convex program there")


# --- islands --------------------------------------------------------------------------------------------------
def islands(layout: Layout, cons: ConstraintSet) -> tuple[int, np.ndarray]:
    """(count, island label per dynamic body) of the graph whose edges are manifolds between dynamic bodies."""
    a = layout.index[cons.body_a]
    b = layout.index[cons.body_b]
    both = (a >= 0) & (b >= 0)
    g = sp.coo_matrix((np.ones(int(both.sum())), (a[both], b[both])), shape=(layout.n, layout.n))
    return connected_components(g, directed=False)


def island_of_rows(layout: Layout, labels: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ia, ib = layout.index[a], layout.index[b]
    return labels[np.where(ia >= 0, ia, ib)]
