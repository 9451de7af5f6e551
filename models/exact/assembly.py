"""Assembly of the exact reference's problems (``models/exact/reference.py``): the mass matrix, the rows of each
phase over the dynamic bodies' velocities (6 columns per body: v then w), the spin rows of the damped manifolds,
and the islands (bodies connected through manifolds between dynamic bodies: independent problems).

The mass matrix M is block diagonal per dynamic body: ``m I3`` on v and the world inertia on w, which is diagonal
(3 words per body) or the full symmetric 3x3 (6 words, ``models/setup/inertia.py``: rotated non-cube bodies in Bullet
2's convention). :class:`Mass` holds M and M^-1 as sparse matrices; for a diagonal table both are ``diags`` of the
per-column values, so the diagonal path's arithmetic (and its cached references) is unchanged."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from models.setup.constraints import BodyTable, ConstraintSet

EIGEN_TOLERANCE = 1e-9  # relative: n is an eigenvector of the inverse inertia
SPAN_TOLERANCE = 1e-12  # relative singular value below which a body's damped normals add no spin row


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


@dataclass(frozen=True)
class Mass:
    """M and M^-1 over some dynamic bodies' columns (6 per body), sparse and block diagonal."""

    mass: sp.csr_matrix
    inv: sp.csr_matrix

    def sub(self, cols: np.ndarray) -> "Mass":
        """The blocks of the bodies whose columns are ``cols`` (whole bodies, so still each other's inverse)."""
        return Mass(self.mass[cols][:, cols].tocsr(), self.inv[cols][:, cols].tocsr())

    def norm2(self, x: np.ndarray) -> float:
        """``x^T M x``."""
        return float(x @ (self.mass @ x))

    def row_norms2(self, G: sp.spmatrix) -> np.ndarray:
        """``diag(G M^-1 G^T)``: each row's effective inverse mass."""
        G = sp.csr_matrix(G)
        return np.asarray((G @ self.inv).multiply(G).sum(axis=1)).ravel()


def inverse_inertia_matrices(inv_inertia: np.ndarray) -> np.ndarray:
    """(N, 3, 3) symmetric matrices of a body table's (N, 3) diagonal or (N, 6) words
    (``models.setup.inertia.FULL_ORDER``)."""
    v = np.asarray(inv_inertia, dtype=np.float64)
    out = np.zeros((v.shape[0], 3, 3))
    out[:, [0, 1, 2], [0, 1, 2]] = v[:, :3]
    if v.shape[1] == 6:
        for k, (i, j) in enumerate(((0, 1), (0, 2), (1, 2))):
            out[:, i, j] = out[:, j, i] = v[:, 3 + k]
    elif v.shape[1] != 3:
        raise ExactReferenceError(f"an inverse inertia has 3 or 6 words per body, got {v.shape[1]}")
    return out


def block_mass(inv_mass: np.ndarray, inertia_inv: np.ndarray) -> Mass:
    """M and M^-1 with 3x3 blocks on w (``inertia_inv`` (n, 3, 3)), ``m I3`` on v."""
    n = inv_mass.shape[0]
    lin = 6 * np.arange(n)[:, None] + np.arange(3)[None, :]
    ang = 6 * np.arange(n)[:, None, None] + 3 + np.zeros((1, 3, 3), dtype=np.int64)
    rows = np.concatenate([lin.ravel(), (ang + np.arange(3)[None, :, None]).ravel()])
    cols = np.concatenate([lin.ravel(), (ang + np.arange(3)[None, None, :]).ravel()])

    def blocks(lin_vals: np.ndarray, ang_vals: np.ndarray) -> sp.csr_matrix:
        data = np.concatenate([np.repeat(lin_vals, 3), ang_vals.ravel()])
        return sp.csr_matrix((data, (rows, cols)), shape=(6 * n, 6 * n))

    return Mass(blocks(1.0 / inv_mass, np.linalg.inv(inertia_inv)), blocks(inv_mass, inertia_inv))


class Layout:
    """Column layout: dynamic body k owns columns 6k..6k+2 (v) and 6k+3..6k+5 (w)."""

    def __init__(self, bodies: BodyTable):
        self.bodies = bodies
        self.dynamic = bodies.dynamic
        self.index = np.full(bodies.num_bodies, -1, dtype=np.int64)
        self.index[self.dynamic] = np.arange(int(self.dynamic.sum()))
        self.n = int(self.dynamic.sum())
        inv_mass = bodies.inv_mass[self.dynamic]
        self.inertia_inv = inverse_inertia_matrices(bodies.inv_inertia[self.dynamic])  # (n, 3, 3) world I^-1
        self.full = bool(np.any(self.inertia_inv[:, [0, 0, 1], [1, 2, 2]] != 0.0))
        if not (np.all(np.isfinite(inv_mass)) and np.all(np.isfinite(self.inertia_inv))):
            raise ExactReferenceError("a dynamic body has a non-finite inverse mass or inertia")
        eig = np.linalg.eigvalsh(self.inertia_inv) if self.n else np.ones((0, 3))
        if np.any(~(inv_mass > 0)) or np.any(~(eig > 0)):
            raise ExactReferenceError("a dynamic body has a non-positive inverse mass or an inverse inertia that is "
                                      "not positive definite")
        self.max_inv_inertia = float(eig.max(initial=0.0))  # largest eigenvalue: |dw| <= B sqrt(this)
        inv = np.concatenate([np.repeat(inv_mass[:, None], 3, axis=1), self.inertia_inv[:, [0, 1, 2], [0, 1, 2]]],
                             axis=1)
        self.inv_m = inv.ravel()  # diag(M^-1), (6n,)
        self.mass = self._mass(inv_mass)

    def _mass(self, inv_mass: np.ndarray) -> Mass:
        if not self.full:
            return Mass(sp.diags(1.0 / self.inv_m, format="csr"), sp.diags(self.inv_m, format="csr"))
        return block_mass(inv_mass, self.inertia_inv)

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


def spin_rows_off_eigen(layout: Layout, N: sp.csr_matrix) -> np.ndarray:
    """Per spin row (a unit direction n on one body's w columns, orthonormal per body), how far ``I^-1 n`` leaves
    the span S of that body's spin rows: ``|(1 - N^T N) I^-1 n| / |I^-1 n|``. Where every row is within
    EIGEN_TOLERANCE, S is invariant under the body's I^-1, the damping (which moves w within S) and the QP's
    stationarity (within I^-1 S) agree, and the friction phase is a convex QP; elsewhere its fixed point solves a
    non-symmetric box complementarity problem (``models/exact/reference.py``)."""
    N = sp.csr_matrix(N)
    if not N.nnz:
        return np.zeros(N.shape[0])
    Nc = N.tocoo()
    vec = np.zeros((N.shape[0], 3))
    body = np.zeros(N.shape[0], dtype=np.int64)
    vec[Nc.row, Nc.col % 6 - 3] = Nc.data
    body[Nc.row] = Nc.col // 6
    iin = np.einsum("kij,kj->ki", layout.inertia_inv[body], vec)
    cols = 6 * body[:, None] + 3 + np.arange(3)[None, :]
    X = sp.csr_matrix((iin.ravel(), (np.repeat(np.arange(N.shape[0]), 3), cols.ravel())), shape=N.shape)
    off = X - (X @ N.T) @ N
    return np.sqrt(np.asarray(off.multiply(off).sum(axis=1)).ravel()) / np.maximum(np.linalg.norm(iin, axis=1),
                                                                                      1e-300)


def not_a_qp_message(layout: Layout, N: sp.csr_matrix, off: np.ndarray, sel: np.ndarray) -> str:
    """Which spin row makes the friction phase of rows ``sel`` of N no convex QP, for messages."""
    worst = int(sel[np.argmax(off[sel])])
    row = N.getrow(worst).tocoo()
    body = int(layout.dynamic.nonzero()[0][row.col[0] // 6])
    n = np.zeros(3)
    n[row.col % 6 - 3] = row.data
    return (f"spin damping on body {body}: the damped direction {n.round(6).tolist()} is no eigenvector of its "
            f"inverse inertia (relative {off[worst]:.1e})")


def friction_limits(cons: ConstraintSet, normal: np.ndarray, mu: float) -> np.ndarray:
    """Each manifold's friction box ``mu ((lam0 + lam1) + (lam2 + lam3))`` (the pass's order), mu the manifold's own
    coefficient where the constraints carry one (Bullet 2's combined friction), else ``mu``."""
    coeff = cons.friction[:, 0] if cons.per_manifold_friction else mu
    return coeff * ((normal[:, 0] + normal[:, 1]) + (normal[:, 2] + normal[:, 3]))


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
