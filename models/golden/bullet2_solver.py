"""Bullet 2's ``btSequentialImpulseConstraintSolver`` in float64, as pybullet 3.2.7 runs it for btRigidBody bodies
(boxes, spheres, capsules, cylinders, convex hulls and compounds of them).

Reproduces one ``stepSimulation`` of a captured frame (``models.scenes.capture_frame``): the same rows in the
same order with the same floating-point operation order as Bullet's scalar reference row solvers (pybullet is
built with BT_USE_DOUBLE_PRECISION, no SSE), so the post-step velocities match pybullet to round-off.
The row set-up follows Bullet's ``btSequentialImpulseConstraintSolver.cpp``. Requirements on the frame (as
``models.scenes`` sets up): maximal-coordinate bodies created in frame order, warmStartingFactor 0,
deterministicOverlappingPairs 1, no damping, restitution 0, no rolling friction or friction anchors, and at most
one Bullet manifold per pair (a compound resting on several of its children has several, in an order pybullet
does not report). Each manifold is taken from the side and in the order Bullet's solver took it
(:func:`solver_order`).

Per contact point (n = normal_on_b, B -> A; rA = point_on_a - x_A, rB = point_on_b - x_B):

* one normal row: J = (n, rA x n, -n, -(rB x n)); pen = distance + slop; rhs from
  -(J v) (v including the external gravity impulse g dt) and pen: pen > 0 -> -pen/dt (speculative);
  else erp2 * (-pen)/dt, which goes to a separate split-impulse (position-only) row if pen <= -0.04;
* two friction rows along velocity-dependent directions (dir1 = tangential relative velocity, dir2 = dir1 x n;
  btPlaneSpace1(n) if that velocity is ~0), box limits +-mu lambda_n with mu = muA*muB, skipped while the
  point's lambda_n <= 0.

Per iteration: all normal rows, then all friction rows (Gauss-Seidel), per island (only matters for an
early exit with solverResidualThreshold > 0). Result: v = (v0 + dv) + g dt, w = (w0 + dw) + gyroscopic term.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from models.setup.constraints import combined_friction
from models.formats.frame import Frame
from models.setup.inertia import quat_to_matrix, rotate_diagonal

DBL_EPSILON = float(np.finfo(np.float64).eps)
SIMDSQRT12 = 0.7071067811865475244008443621048490


@dataclass
class SolverSettings:
    iterations: int = 10
    dt: float = 1.0 / 60.0
    erp2: float = 0.08
    slop: float = 1e-5
    split_impulse: bool = True
    split_threshold: float = -0.04
    residual_threshold: float = 0.0
    sor: float = 1.0
    global_cfm: float = 0.0
    gyroscopic: bool = True  # btRigidBody's default BT_ENABLE_GYROSCOPIC_FORCE_IMPLICIT_BODY

    @classmethod
    def from_frame(cls, frame: Frame) -> "SolverSettings":
        s: dict[str, Any] = frame.meta.get("solver", {})
        if float(s.get("warmStartingFactor", 0.0)) != 0.0:
            raise ValueError("frame was captured with warm starting; the reference needs warmStartingFactor=0")
        return cls(
            iterations=int(s.get("numSolverIterations", 10)),
            dt=float(s.get("fixedTimeStep", frame.dt)),
            erp2=float(s.get("contactERP", 0.08)),
            slop=float(s.get("contactSlop", 1e-5)),
            split_impulse=bool(s.get("useSplitImpulse", 1)),
            split_threshold=float(s.get("splitImpulsePenetrationThreshold", -0.04)),
            residual_threshold=float(s.get("solverResidualThreshold", 0.0)),
        )


@dataclass
class Bullet2Result:
    linear_velocity: np.ndarray  # (N,3) post-step
    angular_velocity: np.ndarray  # (N,3)
    normal_impulse: np.ndarray  # (M,4) N s (0 for unused points)
    friction_impulse1: np.ndarray  # (M,4)
    friction_impulse2: np.ndarray  # (M,4)
    lateral_dir1: np.ndarray  # (M,4,3) friction directions used
    lateral_dir2: np.ndarray  # (M,4,3)
    push_velocity: np.ndarray  # (N,3) split-impulse position correction velocities (positions only)
    turn_velocity: np.ndarray  # (N,3) (Bullet integrates turn_velocity * splitImpulseTurnErp 0.1)
    iterations_run: np.ndarray  # (islands,) velocity iterations each island ran


# ---- Bullet's vector operations, in its operation order (vectorised over rows) -------------------


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                     a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


def _matvec(m: np.ndarray, v: np.ndarray) -> np.ndarray:
    return np.stack([_dot(m[..., i, :], v) for i in range(3)], axis=-1)


def _matmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    for i in range(3):
        for j in range(3):
            out[..., i, j] = a[..., i, 0] * b[..., 0, j] + a[..., i, 1] * b[..., 1, j] + a[..., i, 2] * b[..., 2, j]
    return out


def _quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """btQuatRotate: (q * v) * q^-1, Bullet's operation order."""
    qx, qy, qz, qw = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    vx, vy, vz = v[..., 0], v[..., 1], v[..., 2]
    # q * v (btQuaternion operator*(quat, vec3))
    ax = qw * vx + qy * vz - qz * vy
    ay = qw * vy + qz * vx - qx * vz
    az = qw * vz + qx * vy - qy * vx
    aw = -qx * vx - qy * vy - qz * vz
    # a *= q.inverse() = (-qx, -qy, -qz, qw)
    bx, by, bz, bw = -qx, -qy, -qz, qw
    rx = aw * bx + ax * bw + ay * bz - az * by
    ry = aw * by + ay * bw + az * bx - ax * bz
    rz = aw * bz + az * bw + ax * by - ay * bx
    return np.stack([rx, ry, rz], axis=-1)


def _skew(v: np.ndarray) -> np.ndarray:
    """btVector3::getSkewSymmetricMatrix rows."""
    z = np.zeros_like(v[..., 0])
    return np.stack([np.stack([z, -v[..., 2], v[..., 1]], -1),
                     np.stack([v[..., 2], z, -v[..., 0]], -1),
                     np.stack([-v[..., 1], v[..., 0], z], -1)], axis=-2)


def gyroscopic_impulse_implicit_body(q: np.ndarray, w: np.ndarray, inertia: np.ndarray, dt: float) -> np.ndarray:
    """btRigidBody::computeGyroscopicImpulseImplicit_Body (one Newton step in the body frame)."""
    qinv = np.concatenate([-q[..., :3], q[..., 3:]], axis=-1)
    wb = _quat_rotate(qinv, w)
    ib = np.zeros(w.shape[:-1] + (3, 3))
    for k in range(3):
        ib[..., k, k] = inertia[..., k]
    ibo = _matvec(ib, wb)
    f = dt * _cross(wb, ibo)
    skew0 = _skew(wb)
    skew1 = _skew(_matvec(ib, wb))
    jac = ib + (_matmul(skew0, ib) - skew1) * dt
    c1, c2, c3 = jac[..., :, 0], jac[..., :, 1], jac[..., :, 2]
    det = _dot(c1, _cross(c2, c3))
    det = np.where(np.abs(det) > DBL_EPSILON, 1.0 / np.where(det == 0, 1.0, det), det)
    x = np.stack([det * _dot(f, _cross(c2, c3)), det * _dot(c1, _cross(f, c3)), det * _dot(c1, _cross(c2, f))], -1)
    wb = wb - x
    return _quat_rotate(q, wb) - w


def plane_space(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """btPlaneSpace1."""
    p = np.zeros_like(n)
    q = np.zeros_like(n)
    big_z = np.abs(n[:, 2]) > SIMDSQRT12
    a1 = n[:, 1] * n[:, 1] + n[:, 2] * n[:, 2]
    a2 = n[:, 0] * n[:, 0] + n[:, 1] * n[:, 1]
    a = np.where(big_z, a1, a2)
    with np.errstate(divide="ignore"):
        k = 1.0 / np.sqrt(a)
    # |n_z| > sqrt(1/2)
    pz1 = n[:, 1] * k
    py1 = -n[:, 2] * k
    # else
    px2 = -n[:, 1] * k
    py2 = n[:, 0] * k
    p[:, 0] = np.where(big_z, 0.0, px2)
    p[:, 1] = np.where(big_z, py1, py2)
    p[:, 2] = np.where(big_z, pz1, 0.0)
    q[:, 0] = np.where(big_z, a * k, -n[:, 2] * py2)
    q[:, 1] = np.where(big_z, -n[:, 0] * pz1, n[:, 2] * px2)
    q[:, 2] = np.where(big_z, n[:, 0] * py1, a * k)
    return p, q


def _islands(n_bodies: int, a: np.ndarray, b: np.ndarray, dynamic: np.ndarray) -> np.ndarray:
    """Island id per body (union-find over manifolds between dynamic bodies); -1 for static bodies."""
    parent = list(range(n_bodies))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i, j in zip(a.tolist(), b.tolist()):
        if dynamic[i] and dynamic[j]:
            ri, rj = find(i), find(j)
            if ri != rj:
                parent[max(ri, rj)] = min(ri, rj)
    return np.asarray([find(i) if dynamic[i] else -1 for i in range(n_bodies)], dtype=np.int64)


# ---- the solver ---------------------------------------------------------------------------------


@dataclass
class _BodyTerms:
    """Each body's solver terms (``btSolverBody``): zero for static bodies (Bullet's one fixed solver body)."""

    dyn: np.ndarray  # (N,) bool
    invm: np.ndarray  # (N,)
    inv_iw: np.ndarray  # (N,3,3) m_invInertiaTensorWorld
    ext_f: np.ndarray  # (N,3) external (gravity) impulse, as a velocity
    ext_t: np.ndarray  # (N,3) external torque impulse (the gyroscopic term), as an angular velocity


def _body_terms(frame: Frame, s: SolverSettings) -> _BodyTerms:
    dt = s.dt
    n_bodies = frame.num_bodies
    invm = frame.inv_mass.astype(np.float64)
    dyn = invm != 0.0
    q = frame.orientation
    inertia = frame.inertia_local
    with np.errstate(divide="ignore"):
        inv_inertia = np.where(inertia != 0.0, 1.0 / np.where(inertia == 0.0, 1.0, inertia), 0.0)
    inv_inertia[~dyn] = 0.0
    # m_invInertiaTensorWorld = basis.scaled(invInertiaLocal) * basis.transpose()
    inv_iw = rotate_diagonal(q, inv_inertia)
    inv_iw[~dyn] = 0.0
    # external impulses: force = gravity * (1/invMass); (force * invMass) * dt
    g = frame.gravity
    ext_f = np.zeros((n_bodies, 3))
    ext_t = np.zeros((n_bodies, 3))
    with np.errstate(divide="ignore"):
        mass = np.where(dyn, 1.0 / np.where(dyn, invm, 1.0), 0.0)
    ext_f[dyn] = ((g[None, :] * mass[dyn, None]) * invm[dyn, None]) * dt
    ext_t[dyn] = _matvec(inv_iw[dyn], np.zeros((int(dyn.sum()), 3))) * dt
    if s.gyroscopic and dyn.any():
        ext_t[dyn] = ext_t[dyn] + gyroscopic_impulse_implicit_body(q[dyn], frame.angular_velocity[dyn], inertia[dyn], dt)
    return _BodyTerms(dyn, invm, inv_iw, ext_f, ext_t)


def _solver_velocities(frame: Frame, bt: _BodyTerms, ia: np.ndarray, ib: np.ndarray) -> tuple[np.ndarray, ...]:
    """Per row: the two solver bodies' velocities and external impulses (lva, lvb, ava, avb, efa, efb, eta, etb;
    zero for the fixed body)."""
    da = bt.dyn[ia][:, None]
    db = bt.dyn[ib][:, None]
    zero3 = np.zeros((ia.shape[0], 3))
    v0, w0 = frame.linear_velocity, frame.angular_velocity
    return (np.where(da, v0[ia], zero3), np.where(db, v0[ib], zero3), np.where(da, w0[ia], zero3),
            np.where(db, w0[ib], zero3), np.where(da, bt.ext_f[ia], zero3), np.where(db, bt.ext_f[ib], zero3),
            np.where(da, bt.ext_t[ia], zero3), np.where(db, bt.ext_t[ib], zero3))


def _friction_directions(frame: Frame, bt: _BodyTerms, mi: np.ndarray, pi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """convertContact's two friction directions of the rows (mi, pi), velocity dependent: dir1 along the
    tangential relative velocity of A against B at the contact, dir2 = dir1 x n; btPlaneSpace1(n) where that
    velocity is ~0."""
    ia = frame.body_a[mi].astype(np.int64)
    ib = frame.body_b[mi].astype(np.int64)
    n = frame.normal_on_b[mi, pi]
    ra = frame.point_on_a[mi, pi] - frame.position[ia]
    rb = frame.point_on_b[mi, pi] - frame.position[ib]
    lva, lvb, ava, avb, efa, efb, eta, etb = _solver_velocities(frame, bt, ia, ib)
    zero3 = np.zeros_like(n)
    vel1 = np.where(bt.dyn[ia][:, None], lva + efa + _cross(ava + eta, ra), zero3)
    vel2 = np.where(bt.dyn[ib][:, None], lvb + efb + _cross(avb + etb, rb), zero3)
    vel = vel1 - vel2
    rv = _dot(n, vel)
    lat = vel - n * rv[:, None]
    lat2 = _dot(lat, lat)
    use_vel = lat2 > DBL_EPSILON
    with np.errstate(divide="ignore", invalid="ignore"):
        dir1v = lat * (1.0 / np.sqrt(lat2))[:, None]
        dir2v = _cross(dir1v, n)
        dir2v = dir2v * (1.0 / np.sqrt(_dot(dir2v, dir2v)))[:, None]
    ps1, ps2 = plane_space(n)
    return np.where(use_vel[:, None], dir1v, ps1), np.where(use_vel[:, None], dir2v, ps2)


_MANIFOLD_FIELDS = ("body_a", "body_b", "num_points", "point_on_a", "point_on_b", "normal_on_b", "distance",
                    "normal_force", "lateral_friction1", "lateral_dir1", "lateral_friction2", "lateral_dir2")


def solver_order(frame: Frame, settings: SolverSettings | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The orientation and order in which pybullet's solver took the frame's manifolds: (flipped (M,) bool, order
    (M,) the frame's manifold indices in solver order).

    A frame holds each manifold as (a, b) with a < b (``models.scenes.contact_capture``), but Bullet's manifold has
    its own body0: the lower broadphase id for two primitives, the compound for a compound against a primitive
    (``btCompoundCollisionAlgorithm`` creates its child manifolds with the compound first), whatever the
    algorithm chose otherwise. getContactPoints does not report it, but it reports the friction directions as the
    solver computed them from body0's side (dir1 along body0's tangential velocity against body1, or
    btPlaneSpace1 of body0's normal; turned to body1's side both change sign), so a manifold is ``flipped`` where
    its reported dir1 points against the one computed from a's side. The solver then takes an island's manifolds
    sorted by (body0, body1) broadphase id (``deterministicOverlappingPairs``), which is the frame index for
    bodies created in frame order. Unknowable, and so not reproduced: the order of several Bullet manifolds of
    one pair (a compound's child manifolds: the island sort is unstable among them)."""
    s = settings or SolverSettings.from_frame(frame)
    valid = np.arange(4)[None, :] < frame.num_points[:, None]
    mi, pi = np.nonzero(valid)
    dir1, _ = _friction_directions(frame, _body_terms(frame, s), mi, pi)
    first = np.concatenate([[True], mi[1:] != mi[:-1]]) if mi.size else np.zeros(0, bool)
    flipped = np.zeros(frame.num_manifolds, bool)
    flipped[mi[first]] = _dot(dir1, frame.lateral_dir1[mi, pi])[first] < 0.0
    body0 = np.where(flipped, frame.body_b, frame.body_a)
    body1 = np.where(flipped, frame.body_a, frame.body_b)
    return flipped, np.lexsort((body1, body0))


def _in_solver_order(frame: Frame, flipped: np.ndarray, order: np.ndarray) -> Frame:
    """The frame with its manifolds turned to Bullet's body0 (points swapped, normal negated) and in solver order."""
    f = dataclasses.replace(frame)
    fl = flipped[:, None]
    turned = dict(body_a=np.where(flipped, frame.body_b, frame.body_a), body_b=np.where(flipped, frame.body_a, frame.body_b),
                  point_on_a=np.where(fl[..., None], frame.point_on_b, frame.point_on_a),
                  point_on_b=np.where(fl[..., None], frame.point_on_a, frame.point_on_b),
                  normal_on_b=np.where(fl[..., None], -frame.normal_on_b, frame.normal_on_b))
    for key in _MANIFOLD_FIELDS:
        setattr(f, key, turned.get(key, getattr(frame, key))[order])
    return f


def solve_frame(frame: Frame, settings: SolverSettings | None = None) -> Bullet2Result:
    """pybullet's step of the frame, its manifolds in the orientation and order its solver took them
    (:func:`solver_order`); the per-point results are in the frame's manifold order, the friction impulses and
    directions as pybullet reports them (from Bullet's body0 side)."""
    s = settings or SolverSettings.from_frame(frame)
    flipped, order = solver_order(frame, s)
    r = _solve(_in_solver_order(frame, flipped, order), s)
    back = np.argsort(order)
    return dataclasses.replace(r, **{k: getattr(r, k)[back] for k in _PER_POINT_RESULTS})


_PER_POINT_RESULTS = ("normal_impulse", "friction_impulse1", "friction_impulse2", "lateral_dir1", "lateral_dir2")


def _solve(frame: Frame, s: SolverSettings) -> Bullet2Result:
    """The step of a frame whose manifolds are in Bullet's orientation and solver order."""
    dt = s.dt
    inv_dt = 1.0 / dt
    n_bodies = frame.num_bodies
    bt = _body_terms(frame, s)
    dyn, invm, inv_iw, ext_f, ext_t = bt.dyn, bt.invm, bt.inv_iw, bt.ext_f, bt.ext_t
    x = frame.position
    v0 = frame.linear_velocity
    w0 = frame.angular_velocity

    # ---- rows (one normal and two friction rows per valid point, in manifold x point order)
    m_count = frame.num_manifolds
    valid = np.arange(4)[None, :] < frame.num_points[:, None]
    mi, pi = np.nonzero(valid)  # row-major: manifold order, then point order
    ia = frame.body_a[mi].astype(np.int64)
    ib = frame.body_b[mi].astype(np.int64)
    da = dyn[ia][:, None]
    db = dyn[ib][:, None]
    n = frame.normal_on_b[mi, pi]
    pa = frame.point_on_a[mi, pi]
    pb = frame.point_on_b[mi, pi]
    dist = frame.distance[mi, pi]
    mu = combined_friction(frame.friction, ia, ib)
    ra = pa - x[ia]
    rb = pb - x[ib]
    zero3 = np.zeros_like(n)
    iwa, iwb = inv_iw[ia], inv_iw[ib]
    ima = np.where(da[:, 0], invm[ia], 0.0)
    imb = np.where(db[:, 0], invm[ib], 0.0)
    # solver-body velocities (the fixed body has zero everything)
    lva, lvb, ava, avb, efa, efb, eta, etb = _solver_velocities(frame, bt, ia, ib)

    # normal rows (setupContactConstraint)
    torque0 = _cross(ra, n)
    torque1 = _cross(rb, n)
    ang_a = np.where(da, _matvec(iwa, torque0), zero3)
    ang_b = np.where(db, _matvec(iwb, -torque1), zero3)
    denom0 = np.where(da[:, 0], ima + _dot(n, _cross(ang_a, ra)), 0.0)
    denom1 = np.where(db[:, 0], imb + _dot(n, _cross(-ang_b, rb)), 0.0)
    cfm = s.global_cfm * inv_dt
    jac_n = s.sor / (denom0 + denom1 + cfm)
    n1 = np.where(da, n, zero3)
    t1 = np.where(da, torque0, zero3)
    n2 = np.where(db, -n, zero3)
    t2 = np.where(db, -torque1, zero3)
    pen = dist + s.slop
    rel_vel = (_dot(n1, lva + efa) + _dot(t1, ava + eta)) + (_dot(n2, lvb + efb) + _dot(t2, avb + etb))
    vel_err = 0.0 - rel_vel
    pos_err = np.where(pen > 0, 0.0, -pen * s.erp2 * inv_dt)
    vel_err = np.where(pen > 0, vel_err - pen * inv_dt, vel_err)
    pen_imp = pos_err * jac_n
    vel_imp = vel_err * jac_n
    split = np.zeros_like(pen, dtype=bool) if not s.split_impulse else ~(pen > s.split_threshold)
    rhs_n = np.where(split, vel_imp, pen_imp + vel_imp)
    rhs_pen = np.where(split, pen_imp, 0.0)
    cfm_n = cfm * jac_n
    lin_a_n = n1 * ima[:, None]
    lin_b_n = n2 * imb[:, None]

    dir1, dir2 = _friction_directions(frame, bt, mi, pi)

    def friction_rows(d: np.ndarray) -> dict[str, np.ndarray]:
        f1 = np.where(da, d, zero3)
        f2 = np.where(db, -d, zero3)
        ft1 = np.where(da, _cross(ra, f1), zero3)
        ft2 = np.where(db, _cross(rb, f2), zero3)
        fa = np.where(da, _matvec(iwa, ft1), zero3)
        fb = np.where(db, _matvec(iwb, ft2), zero3)
        den0 = np.where(da[:, 0], ima + _dot(d, _cross(fa, ra)), 0.0)
        den1 = np.where(db[:, 0], imb + _dot(d, _cross(-fb, rb)), 0.0)
        jac = s.sor / (den0 + den1)
        rv_f = (_dot(f1, lva + efa) + _dot(ft1, ava)) + (_dot(f2, lvb + efb) + _dot(ft2, avb))
        rhs = (0.0 - rv_f) * jac
        return dict(n1=f1, t1=ft1, n2=f2, t2=ft2, ang_a=fa, ang_b=fb, jac=jac, rhs=rhs,
                    lin_a=f1 * ima[:, None], lin_b=f2 * imb[:, None])

    fr1 = friction_rows(dir1)
    fr2 = friction_rows(dir2)

    # ---- islands and the sequential sweeps (plain Python floats, Bullet's operation order)
    island = _islands(n_bodies, frame.body_a, frame.body_b, dyn)
    row_island = np.where(dyn[ia], island[ia], island[ib])
    n_rows = int(mi.shape[0])

    def pack(ia_: np.ndarray, ib_: np.ndarray, r: dict[str, np.ndarray]) -> list[tuple]:
        cols = [np.where(da[:, 0], 6 * ia_, -1), np.where(db[:, 0], 6 * ib_, -1)]
        for key in ("n1", "t1", "n2", "t2", "lin_a", "ang_a", "lin_b", "ang_b"):
            cols += [r[key][:, 0], r[key][:, 1], r[key][:, 2]]
        cols += [r["jac"], r["rhs"], r["cfm"]]
        return list(zip(*[c.tolist() for c in cols]))

    normal_rows = pack(ia, ib, dict(n1=n1, t1=t1, n2=n2, t2=t2, lin_a=lin_a_n, ang_a=ang_a, lin_b=lin_b_n, ang_b=ang_b,
                                    jac=jac_n, rhs=rhs_n, cfm=np.broadcast_to(cfm_n, jac_n.shape)))
    pen_rows = pack(ia, ib, dict(n1=n1, t1=t1, n2=n2, t2=t2, lin_a=lin_a_n, ang_a=ang_a, lin_b=lin_b_n, ang_b=ang_b,
                                 jac=jac_n, rhs=rhs_pen, cfm=np.broadcast_to(cfm_n, jac_n.shape)))
    zeros_r = np.zeros(n_rows)
    f1_rows = pack(ia, ib, dict(fr1, cfm=zeros_r))
    f2_rows = pack(ia, ib, dict(fr2, cfm=zeros_r))
    mu_l = mu.tolist()

    delta = [0.0] * (6 * n_bodies)  # dv, dw per body
    push = [0.0] * (6 * n_bodies)  # push, turn velocity per body
    lam_n = [0.0] * n_rows
    lam_p = [0.0] * n_rows
    lam_f1 = [0.0] * n_rows
    lam_f2 = [0.0] * n_rows

    order = np.argsort(row_island, kind="stable")
    bounds = np.flatnonzero(np.diff(row_island[order])) + 1
    island_rows = [g.tolist() for g in np.split(order, bounds)] if n_rows else []
    iterations_run = []
    for rows in island_rows:
        if s.split_impulse:
            for it in range(s.iterations):
                res = 0.0
                for k in rows:
                    if pen_rows[k][-2] == 0.0:  # m_rhsPenetration == 0 -> skipped, residual 0
                        continue
                    lam_p[k], r = _resolve(push, pen_rows[k], lam_p[k], 0.0, None)
                    res = max(res, r * r)
                if res <= s.residual_threshold or it >= s.iterations - 1:
                    break
        for it in range(s.iterations):
            res = 0.0
            for k in rows:
                lam_n[k], r = _resolve(delta, normal_rows[k], lam_n[k], 0.0, None)
                res = max(res, r * r)
            for k in rows:
                total = lam_n[k]
                if total > 0.0:
                    lim = mu_l[k] * total
                    lam_f1[k], r = _resolve(delta, f1_rows[k], lam_f1[k], -lim, lim)
                    res = max(res, r * r)
                    lam_f2[k], r = _resolve(delta, f2_rows[k], lam_f2[k], -lim, lim)
                    res = max(res, r * r)
            if res <= s.residual_threshold or it >= s.iterations - 1:
                iterations_run.append(it + 1)
                break

    dvw = np.asarray(delta).reshape(n_bodies, 6)
    pt = np.asarray(push).reshape(n_bodies, 6)
    lin = frame.linear_velocity.copy()
    ang = frame.angular_velocity.copy()
    lin[dyn] = (v0[dyn] + dvw[dyn, :3]) + ext_f[dyn]
    ang[dyn] = (w0[dyn] + dvw[dyn, 3:]) + ext_t[dyn]

    def per_point(vals: list[float] | np.ndarray, width: int = 0) -> np.ndarray:
        out = np.zeros((m_count, 4) + ((width,) if width else ()))
        out[mi, pi] = np.asarray(vals)
        return out

    return Bullet2Result(
        linear_velocity=lin, angular_velocity=ang,
        normal_impulse=per_point(lam_n), friction_impulse1=per_point(lam_f1), friction_impulse2=per_point(lam_f2),
        lateral_dir1=per_point(dir1, 3), lateral_dir2=per_point(dir2, 3),
        push_velocity=pt[:, :3].copy(), turn_velocity=pt[:, 3:].copy(),
        iterations_run=np.asarray(iterations_run, dtype=np.int64))


def _resolve(d: list[float], row: tuple, applied: float, lo: float, hi: float | None) -> tuple[float, float]:
    """resolveSingleConstraintRowLowerLimit (hi None) / ...Generic on the delta (or push/turn) velocities d."""
    (oa, ob, n1x, n1y, n1z, t1x, t1y, t1z, n2x, n2y, n2z, t2x, t2y, t2z,
     lax, lay, laz, aax, aay, aaz, lbx, lby, lbz, abx, aby, abz, jac, rhs, cfm) = row
    delta = rhs - applied * cfm
    if oa >= 0:
        dv1 = (n1x * d[oa] + n1y * d[oa + 1] + n1z * d[oa + 2]) + (t1x * d[oa + 3] + t1y * d[oa + 4] + t1z * d[oa + 5])
        delta -= dv1 * jac
    if ob >= 0:
        dv2 = (n2x * d[ob] + n2y * d[ob + 1] + n2z * d[ob + 2]) + (t2x * d[ob + 3] + t2y * d[ob + 4] + t2z * d[ob + 5])
        delta -= dv2 * jac
    total = applied + delta
    if total < lo:
        delta = lo - applied
        applied = lo
    elif hi is not None and total > hi:
        delta = hi - applied
        applied = hi
    else:
        applied = total
    if oa >= 0:
        _apply_delta(d, oa, (lax, lay, laz, aax, aay, aaz), delta)
    if ob >= 0:
        _apply_delta(d, ob, (lbx, lby, lbz, abx, aby, abz), delta)
    return applied, delta * (1.0 / jac)


def _apply_delta(d: list[float], offset: int, lin_ang: tuple[float, ...], delta: float) -> None:
    """Add ``lin_ang * delta`` to one body's six (linear, angular) velocities starting at ``d[offset]``."""
    for i, weight in enumerate(lin_ang):
        d[offset + i] += weight * delta


def compare_with_pybullet(frame: Frame, result: Bullet2Result | None = None) -> dict[str, float]:
    """Max abs differences between our step and pybullet's (velocities in m/s, rad/s; forces in N)."""
    r = result or solve_frame(frame)
    dt = frame.dt
    dyn = frame.inv_mass != 0
    valid = np.arange(4)[None, :] < frame.num_points[:, None]

    def mx(a: np.ndarray) -> float:
        return float(np.max(np.abs(a))) if a.size else 0.0

    return {
        "linear_velocity": mx(r.linear_velocity[dyn] - frame.post_linear_velocity[dyn]),
        "angular_velocity": mx(r.angular_velocity[dyn] - frame.post_angular_velocity[dyn]),
        "normal_force": mx((r.normal_impulse / dt - frame.normal_force)[valid]),
        "lateral_friction1": mx((r.friction_impulse1 / dt - frame.lateral_friction1)[valid]),
        "lateral_friction2": mx((r.friction_impulse2 / dt - frame.lateral_friction2)[valid]),
        "lateral_dir1": mx((r.lateral_dir1 - frame.lateral_dir1)[valid]),
        "lateral_dir2": mx((r.lateral_dir2 - frame.lateral_dir2)[valid]),
    }


__all__ = ["SolverSettings", "Bullet2Result", "solve_frame", "solver_order", "compare_with_pybullet", "quat_to_matrix", "plane_space",
           "gyroscopic_impulse_implicit_body"]

