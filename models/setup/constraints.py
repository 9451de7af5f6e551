"""Contacts to constraints, as Bullet's GPU solver sets them up (``setConstraint4``).

One :class:`ConstraintSet` row per contact manifold (Bullet's ``b3GpuConstraint4``). The setup runs on the
host in float64, once per step, and its results are rounded once to the kernel's number format when
they are streamed (``ConstraintSet.rounded``). Fields and units:

==================  ===========  =========================================================================
field               unit         meaning
==================  ===========  =========================================================================
body_a, body_b      index        the two bodies (frame indices); a static body has inverse mass 0
normal              1            unit contact normal, from B to A (``m_linear.xyz``)
points              m            world contact points on B (``m_worldPos[i].xyz``), zero when unused
num_points          count        valid points, 1..4
jac_inv             1/(kg^-1)    ``m_jacCoeffInv[i] = -1/K_i``, K_i the effective inverse mass of point i
                                 along n; 0 marks an unused point (the row is skipped)
bias                m/s          ``m_b[i] = (d_i + 0.005) * 0.2 / dt`` (5 mm allowed penetration, beta 0.2)
center              m            friction anchor: the centroid of the valid points (``m_center``)
tangent             1            the friction directions the solve kernel uses, planeSpace(-n)
f_jac_inv           1/(kg^-1)    ``m_fJacCoeffInv[j] = -1/Kt_j`` at the centroid
spin_damp           flag         the friction kernel's spin damping applies: a body is static, or the
                                 centroid lies on the line of centres (normalized dot > 0.95)
==================  ===========  =========================================================================

Deliberate deviations from Bullet's GPU code (each documented in docs/architecture.md, "Deliberate deviations"):

* the bias uses the frame's dt (Bullet hard-codes 1/60 here; every scene defaults to 1/60);
* the manifold normal is the normal of its first point (pybullet reports one per point; for box-box
  manifolds they are equal);
* the tangent basis and the spin-damping test, which Bullet recomputes in every friction solve from
  the constant normal and positions, are computed once here and streamed;
* setup arithmetic is float64 (Bullet: float32 with fast_normalize/native_divide);
* K uses the same world inverse inertia as the solve (Bullet's setup uses the unrotated local one,
  ``m_initInvInertia``); the inverse inertia and the friction coefficient follow the frame's Bullet convention
  (``models/setup/inertia.py``; ``friction`` per manifold where the pairs' combined friction differs from the solver's
  one coefficient).
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import Mapping

import numpy as np

from models.formats.frame import Frame
from models.setup.inertia import (AABB_MARGIN, InertiaMode, convention_inverse_inertia, gpu_inverse_inertia,
                                  inertia_mode, quadratic_form)
from models.formats.frame import BulletConvention, convention_of
from models.formats.number_format import Arithmetic

__all__ = ["AABB_MARGIN", "FRICTION_COEFF", "MAX_FRICTION", "BodyTable", "ConstraintSet", "body_table",
           "body_table_from_state", "combined_friction", "gpu_inverse_inertia", "plane_space",
           "setup_constraints"]

POSITION_DRIFT = 0.005  # m, Bullet GPU b3ConstraintCfg.m_positionDrift
POSITION_COEFF = 0.2  # Bullet GPU b3ConstraintCfg.m_positionConstraintCoeff
FRICTION_COEFF = 0.7  # hard-coded in Bullet's solveFriction kernel
MAX_FRICTION = 10.0  # Bullet's clamp of a pair's combined friction (btManifoldResult::calculateCombinedFriction)
SPIN_DAMP_ALIGNMENT = 0.95


@dataclass
class BodyTable:
    """The per-body state the kernel keeps on chip."""

    position: np.ndarray  # (N,3) m
    orientation: np.ndarray  # (N,4) (x,y,z,w)
    linear_velocity: np.ndarray  # (N,3) m/s
    angular_velocity: np.ndarray  # (N,3) rad/s
    inv_mass: np.ndarray  # (N,) 1/kg
    inv_inertia: np.ndarray  # (N,3) world diagonal or (N,6) symmetric 3x3 inverse inertia, 1/(kg m^2) (models/setup/inertia.py)

    @property
    def num_bodies(self) -> int:
        return int(self.inv_mass.shape[0])

    @property
    def dynamic(self) -> np.ndarray:
        return self.inv_mass != 0.0

    @property
    def inertia_mode(self) -> InertiaMode:
        """The inverse-inertia mode a kernel build needs for these bodies: ``scalar`` where every dynamic body is
        isotropic, ``diagonal`` where every world matrix is diagonal (axis-aligned principal axes), else ``full``."""
        return inertia_mode(self.inv_inertia, self.dynamic)

    def copy(self) -> "BodyTable":
        return BodyTable(**{f.name: getattr(self, f.name).copy() for f in fields(self)})

    def rounded(self, arith: Arithmetic) -> "BodyTable":
        return BodyTable(**{f.name: arith.round(getattr(self, f.name)) for f in fields(self)})


@dataclass
class ConstraintSet:
    body_a: np.ndarray  # (M,) int
    body_b: np.ndarray  # (M,) int
    num_points: np.ndarray  # (M,) int
    normal: np.ndarray  # (M,3)
    points: np.ndarray  # (M,4,3)
    jac_inv: np.ndarray  # (M,4)
    bias: np.ndarray  # (M,4)
    center: np.ndarray  # (M,3)
    tangent: np.ndarray  # (M,2,3)
    f_jac_inv: np.ndarray  # (M,2)
    spin_damp: np.ndarray  # (M,) bool
    # (M,1) the pair's friction coefficient where a scene's friction varies; (M,0) (the default): every manifold
    # uses the solver's one coefficient (SolverParams.friction_coeff, the kernel's constant)
    friction: np.ndarray = None  # type: ignore[assignment]

    _REAL_FIELDS = ("normal", "points", "jac_inv", "bias", "center", "tangent", "f_jac_inv", "friction")

    def __post_init__(self) -> None:
        if self.friction is None:
            self.friction = np.zeros((self.body_a.shape[0], 0))
        if self.friction.shape not in ((self.body_a.shape[0], 0), (self.body_a.shape[0], 1)):
            raise ValueError(f"friction has shape {self.friction.shape}, expected ({self.body_a.shape[0]}, 0 or 1)")

    @property
    def per_manifold_friction(self) -> bool:
        return self.friction.shape[-1] == 1

    @property
    def friction_words(self) -> int:
        """Friction-coefficient words per friction record (the kernel build's ``MU_W``): 1 where the manifolds carry
        their own coefficient (the scene's friction varies), 0 where the kernel's one coefficient serves all."""
        return 1 if self.per_manifold_friction else 0

    @property
    def num_manifolds(self) -> int:
        return int(self.body_a.shape[0])

    def rounded(self, arith: Arithmetic) -> "ConstraintSet":
        return replace(self, **{name: arith.round(getattr(self, name)) for name in self._REAL_FIELDS})


def body_table(frame: Frame, gravity_preapplied: bool = True, convention: BulletConvention | None = None) -> BodyTable:
    """The kernel's body table from a pybullet frame (see :func:`body_table_from_state`); the inverse inertia in
    ``convention``, by default the one the frame names (``models.formats.frame.convention_of``), registered at the
    frame's orientation."""
    return body_table_from_state(
        {"position": frame.position, "orientation": frame.orientation, "linear_velocity": frame.linear_velocity,
         "angular_velocity": frame.angular_velocity, "inv_mass": frame.inv_mass, "half_extents": frame.half_extents,
         "inertia_local": frame.inertia_local},
        frame.gravity, frame.dt, gravity_preapplied,
        convention if convention is not None else convention_of(frame.meta))


def body_table_from_state(state: Mapping[str, np.ndarray], gravity: np.ndarray, dt: float,
                          gravity_preapplied: bool = True,
                          convention: BulletConvention = BulletConvention.WORLD_AXES) -> BodyTable:
    """The kernel's body table from pybullet body state (arrays named as in :class:`~models.formats.frame.Frame`;
    ``inertia_local`` is read in the ``bullet2`` convention only). The inverse inertia is that of
    ``convention`` at the state's orientation, in the narrowest mode that holds it (``models/setup/inertia.py``).

    Bullet's GPU integrator adds g*dt to the velocity *after* the position update, so the velocity it
    stores (and solves with) already holds the next step's gravity, whereas pybullet applies g*dt inside
    its solve. With ``gravity_preapplied`` pybullet's velocities are moved to the GPU convention by adding
    g*dt to every dynamic body, so one GPU-style step sees the same free-flight velocity as pybullet's.
    """
    inv_mass = np.asarray(state["inv_mass"], dtype=np.float64)
    lin = np.array(state["linear_velocity"], dtype=np.float64)
    if gravity_preapplied:
        lin[inv_mass != 0.0] += np.asarray(gravity, dtype=np.float64) * dt
    return BodyTable(
        position=np.array(state["position"], dtype=np.float64),
        orientation=np.array(state["orientation"], dtype=np.float64),
        linear_velocity=lin,
        angular_velocity=np.array(state["angular_velocity"], dtype=np.float64),
        inv_mass=inv_mass.copy(),
        inv_inertia=convention_inverse_inertia(convention, np.asarray(state["orientation"], dtype=np.float64),
                                               inv_mass, state["inertia_local"] if "inertia_local" in state else np.zeros_like(lin),
                                               state["half_extents"]),
    )


def plane_space(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bullet's ``b3PlaneSpace1``: two unit tangents orthogonal to n (vectorized over rows)."""
    n = np.asarray(n, dtype=np.float64)
    nx, ny, nz = n[:, 0], n[:, 1], n[:, 2]
    use_z = np.abs(nz) > 0.70710678
    a_z = ny * ny + nz * nz
    k_z = 1.0 / np.sqrt(np.where(use_z, a_z, 1.0))
    p_z = np.stack([np.zeros_like(nx), -nz * k_z, ny * k_z], axis=1)
    q_z = np.stack([a_z * k_z, -nx * p_z[:, 2], nx * p_z[:, 1]], axis=1)
    a_x = nx * nx + ny * ny
    k_x = 1.0 / np.sqrt(np.where(use_z, 1.0, a_x))
    p_x = np.stack([-ny * k_x, nx * k_x, np.zeros_like(nx)], axis=1)
    q_x = np.stack([-nz * p_x[:, 1], nz * p_x[:, 0], a_x * k_x], axis=1)
    p = np.where(use_z[:, None], p_z, p_x)
    q = np.where(use_z[:, None], q_z, q_x)
    return p, q


def _effective_mass(direction: np.ndarray, r_a: np.ndarray, r_b: np.ndarray, bodies: BodyTable,
                    a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """K = m_A^-1 + (r_A x d)^T I_A^-1 (r_A x d) + m_B^-1 + (r_B x d)^T I_B^-1 (r_B x d)."""
    ca = np.cross(r_a, direction)
    cb = np.cross(r_b, direction)
    ia = bodies.inv_inertia[a]
    ib = bodies.inv_inertia[b]
    if ca.ndim == 3:
        ia, ib = ia[:, None, :], ib[:, None, :]
    return (bodies.inv_mass[a].reshape(-1, *([1] * (ca.ndim - 2))) + quadratic_form(ia, ca)
            + bodies.inv_mass[b].reshape(-1, *([1] * (ca.ndim - 2))) + quadratic_form(ib, cb))


def _normalize(v: np.ndarray) -> np.ndarray:
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(norm > 0, norm, 1.0)


def combined_friction(friction: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Bullet's combined friction of each pair: muA * muB clamped to [-10, 10]
    (``btManifoldResult::calculateCombinedFriction``)."""
    return np.clip(np.asarray(friction, dtype=np.float64)[a] * np.asarray(friction, dtype=np.float64)[b],
                   -MAX_FRICTION, MAX_FRICTION)


def setup_constraints(frame: Frame, bodies: BodyTable | None = None,
                      friction_coeff: float | None = None) -> ConstraintSet:
    """Build one Constraint4 per manifold from a frame's contacts (float64, on the host).

    ``friction_coeff`` is the solver's one coefficient (default ``FRICTION_COEFF``, Bullet GPU's 0.7: the
    kernel's constant and ``SolverParams``' default). In the ``bullet2`` convention, where any pair's combined
    friction (pybullet's muA muB) differs from it, every manifold carries its own (``ConstraintSet.friction``:
    the kernel's friction word), a world of one friction too."""
    bodies = bodies if bodies is not None else body_table(frame)
    a = frame.body_a.astype(np.int64)
    b = frame.body_b.astype(np.int64)
    m = a.shape[0]
    valid = np.arange(4)[None, :] < frame.num_points[:, None]
    normal = frame.normal_on_b[:, 0, :].copy()
    points = np.where(valid[..., None], frame.point_on_b, 0.0)
    depth = np.where(valid, frame.distance, 0.0)

    x_a = bodies.position[a]
    x_b = bodies.position[b]
    r_a = points - x_a[:, None, :]
    r_b = points - x_b[:, None, :]
    k = _effective_mass(np.broadcast_to(normal[:, None, :], points.shape), r_a, r_b, bodies, a, b)
    with np.errstate(divide="ignore"):
        jac_inv = np.where(valid, -1.0 / np.where(valid, k, 1.0), 0.0)
    bias = np.where(valid, (depth + POSITION_DRIFT) * POSITION_COEFF / frame.dt, 0.0)

    center = np.sum(points, axis=1) / frame.num_points[:, None]
    t0, t1 = plane_space(-normal)
    tangent = np.stack([t0, t1], axis=1)
    rc_a = center - x_a
    rc_b = center - x_b
    kt = np.stack([_effective_mass(tangent[:, j, :], rc_a, rc_b, bodies, a, b) for j in range(2)], axis=1)
    f_jac_inv = -1.0 / kt

    ab = _normalize(x_b - x_a)
    ac = _normalize(center - x_a)
    aligned = np.sum(ab * ac, axis=1) > SPIN_DAMP_ALIGNMENT
    spin_damp = aligned | (bodies.inv_mass[a] == 0.0) | (bodies.inv_mass[b] == 0.0)
    register = FRICTION_COEFF if friction_coeff is None else friction_coeff
    friction = np.zeros((m, 0))
    if convention_of(frame.meta) is BulletConvention.BULLET2:
        mu = combined_friction(frame.friction, a, b)
        if np.any(mu != register):
            friction = mu[:, None]
    return ConstraintSet(
        body_a=a, body_b=b, num_points=frame.num_points.astype(np.int64), normal=normal, points=points,
        jac_inv=jac_inv, bias=bias, center=center, tangent=tangent, f_jac_inv=f_jac_inv,
        spin_damp=spin_damp.astype(bool), friction=friction,
    ) if m else _empty_constraints()


def _empty_constraints() -> ConstraintSet:
    z = np.zeros
    return ConstraintSet(
        body_a=z(0, np.int64), body_b=z(0, np.int64), num_points=z(0, np.int64), normal=z((0, 3)),
        points=z((0, 4, 3)), jac_inv=z((0, 4)), bias=z((0, 4)), center=z((0, 3)), tangent=z((0, 2, 3)),
        f_jac_inv=z((0, 2)), spin_damp=z(0, bool),
    )
