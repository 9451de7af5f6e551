"""A body's world-frame inverse inertia, in the conventions the solvers use, and how many words it needs.

Conventions (:class:`BulletConvention`), each documented in docs/architecture.md ("Inverse inertia and
friction"); a convention also says where the friction coefficient comes from (``models.setup.constraints``):

* ``bullet2``: Bullet 2's ``btRigidBody::updateInertiaTensor``: the true inertia (pybullet's
  ``getDynamicsInfo`` local inertia diagonal, in the principal-inertia frame whose world orientation is the
  frame's ``orientation``), ``I^-1_world = R diag(1/I_local) R^T`` recomputed every step from the current
  orientation. The default for user worlds and the one pybullet's own step uses. Friction: Bullet's combined
  friction of each pair (``btManifoldResult::calculateCombinedFriction``).
* ``bullet_gpu``: Bullet 3 GPU's ``b3GpuNarrowPhase::registerRigidBody``: the box inertia of the body's AABB
  plus a 0.01 m margin with the full extent taken as a half extent (:func:`gpu_inverse_inertia`), rotated
  once by the registration orientation, ``R(q0) diag R(q0)^T``, and never updated. Friction: the GPU
  solver's hard-coded 0.7.
* ``world_axes``: the AABB diagonal of ``bullet_gpu`` applied in world axes without the rotation: what the
  kernel computes while it carries a diagonal only. Identical to ``bullet_gpu`` for isotropic bodies
  (cubes, spheres) and for bodies registered unrotated, so the thesis scene is the same in both; wrong for
  rotated non-cube bodies. It is the convention of frames that name none (the built-in scenes). Friction as
  ``bullet_gpu``.

A frame names its convention in ``meta["bullet_convention"]``.

Modes (:class:`InertiaMode`): what a body table needs per body, decided from the values
(:func:`inertia_mode`): ``scalar`` (1 word: every dynamic body isotropic), ``diagonal`` (3 words: every
world matrix diagonal, i.e. principal axes along the world axes) or ``full`` (6 words, the symmetric 3x3).
A body table's ``inv_inertia`` is (N, 3) in the scalar and diagonal modes (a scalar body repeats its value)
and (N, 6) in the full mode, words in :data:`FULL_ORDER` (the diagonal first, so each mode's words are a
prefix of the next one's).
"""

from __future__ import annotations

from enum import Enum

import numpy as np

from models.formats.frame import BulletConvention
from models.formats.number_format import Arithmetic

AABB_MARGIN = 0.01  # m, added to each side of the local AABB before Bullet GPU's inertia computation
FULL_ORDER = ("xx", "yy", "zz", "xy", "xz", "yz")


class InertiaMode(str, Enum):
    SCALAR = "scalar"
    DIAGONAL = "diagonal"
    FULL = "full"

    @property
    def words(self) -> int:
        """Inverse-inertia words a body record carries in this mode."""
        return {InertiaMode.SCALAR: 1, InertiaMode.DIAGONAL: 3, InertiaMode.FULL: 6}[self]


def _reciprocal(values: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore"):
        return np.where(values > 0, 1.0 / np.where(values > 0, values, 1.0), 0.0)


def gpu_inverse_inertia(half_extents: np.ndarray, inv_mass: np.ndarray) -> np.ndarray:
    """Bullet GPU's box inertia: from the *full* AABB extent plus margin (``b3GpuNarrowPhase``), (N, 3).

    ``e = 2 h + 2 margin`` is used as a half extent, so the box is ~2x too large per axis (a unit-mass
    2 m cube gets 1/I = 0.36761 instead of 1.5). Static bodies get 0.
    """
    e = 2.0 * np.asarray(half_extents, dtype=np.float64) + 2.0 * AABB_MARGIN
    l2 = (2.0 * e) ** 2
    mass = _reciprocal(np.asarray(inv_mass, dtype=np.float64))
    inertia = np.stack([l2[:, 1] + l2[:, 2], l2[:, 0] + l2[:, 2], l2[:, 0] + l2[:, 1]], axis=1) * (mass / 12.0)[:, None]
    return np.where((np.asarray(inv_mass) > 0)[:, None], _reciprocal(inertia), 0.0)


def true_inverse_inertia(inertia_local: np.ndarray, inv_mass: np.ndarray) -> np.ndarray:
    """1 / pybullet's local principal inertia, (N, 3); 0 for static bodies and zero components."""
    inv = _reciprocal(np.asarray(inertia_local, dtype=np.float64))
    return np.where((np.asarray(inv_mass) != 0)[:, None], inv, 0.0)


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices of quaternions (x, y, z, w), Bullet's ``btMatrix3x3::setRotation`` operation order."""
    q = np.asarray(q, dtype=np.float64)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    d = x * x + y * y + z * z + w * w
    s = 2.0 / d
    xs, ys, zs = x * s, y * s, z * s
    wx, wy, wz = w * xs, w * ys, w * zs
    xx, xy, xz = x * xs, x * ys, x * zs
    yy, yz, zz = y * ys, y * zs, z * zs
    m = np.empty(q.shape[:-1] + (3, 3))
    m[..., 0, 0], m[..., 0, 1], m[..., 0, 2] = 1.0 - (yy + zz), xy - wz, xz + wy
    m[..., 1, 0], m[..., 1, 1], m[..., 1, 2] = xy + wz, 1.0 - (xx + zz), yz - wx
    m[..., 2, 0], m[..., 2, 1], m[..., 2, 2] = xz - wy, yz + wx, 1.0 - (xx + yy)
    return m


def rotate_diagonal(q: np.ndarray, diag: np.ndarray) -> np.ndarray:
    """``R diag R^T`` as (N, 3, 3), Bullet's operation order (``basis.scaled(d) * basis.transpose()``)."""
    rot = quat_to_matrix(q)
    scaled = rot * np.asarray(diag, dtype=np.float64)[:, None, :]
    out = np.empty(rot.shape)
    for i in range(3):
        for j in range(3):
            out[..., i, j] = scaled[..., i, 0] * rot[..., j, 0] + scaled[..., i, 1] * rot[..., j, 1] \
                + scaled[..., i, 2] * rot[..., j, 2]
    return out


def world_inverse_inertia(orientation: np.ndarray, inv_local: np.ndarray) -> np.ndarray:
    """The symmetric world inverse inertia as (N, 6) words in :data:`FULL_ORDER`.

    An isotropic body (three equal local components) gets its value on the diagonal and exact zeros off it
    (``c R R^T = c I``, without the rotation's round-off), so cubes and spheres stay on the scalar path."""
    inv_local = np.asarray(inv_local, dtype=np.float64)
    m = rotate_diagonal(orientation, inv_local)
    out = np.stack([m[:, 0, 0], m[:, 1, 1], m[:, 2, 2], m[:, 0, 1], m[:, 0, 2], m[:, 1, 2]], axis=1)
    iso = (inv_local[:, 0] == inv_local[:, 1]) & (inv_local[:, 1] == inv_local[:, 2])
    out[iso] = np.concatenate([inv_local[iso], np.zeros((int(iso.sum()), 3))], axis=1)
    return out


def inertia_mode(inv_inertia: np.ndarray, dynamic: np.ndarray) -> InertiaMode:
    """The narrowest mode that holds the dynamic bodies' inverse inertia exactly ((N, 3) or (N, 6) words)."""
    v = np.asarray(inv_inertia, dtype=np.float64)[np.asarray(dynamic, dtype=bool)]
    if v.shape[-1] not in (3, 6):
        raise ValueError(f"an inverse inertia has 3 (diagonal) or 6 (symmetric 3x3) words per body, got {v.shape[-1]}")
    if v.shape[-1] == 6 and np.any(v[:, 3:] != 0.0):
        return InertiaMode.FULL
    if np.all((v[:, 0] == v[:, 1]) & (v[:, 1] == v[:, 2])):
        return InertiaMode.SCALAR
    return InertiaMode.DIAGONAL


def compact(inv_inertia: np.ndarray, dynamic: np.ndarray) -> np.ndarray:
    """The body table's ``inv_inertia`` for its mode: (N, 3) in the scalar and diagonal modes, else (N, 6)."""
    v = np.asarray(inv_inertia, dtype=np.float64)
    if v.shape[-1] == 6 and inertia_mode(v, dynamic) is not InertiaMode.FULL:
        return v[:, :3].copy()
    return v.copy()


def convention_inverse_inertia(convention: BulletConvention, orientation: np.ndarray, inv_mass: np.ndarray,
                               inertia_local: np.ndarray, half_extents: np.ndarray) -> np.ndarray:
    """The body table's ``inv_inertia`` of ``convention`` at ``orientation`` (the current one for ``bullet2``,
    the registration orientation for ``bullet_gpu``), compacted to its mode; static bodies get 0."""
    dynamic = np.asarray(inv_mass) != 0.0
    if convention is BulletConvention.BULLET2 and np.any(np.asarray(inertia_local)[dynamic] <= 0.0):
        raise ValueError("the bullet2 convention needs each dynamic body's local inertia (pybullet's getDynamicsInfo), "
                         "and a component is zero, negative or missing")
    if convention is BulletConvention.WORLD_AXES:
        return gpu_inverse_inertia(half_extents, inv_mass)
    if convention is BulletConvention.BULLET_GPU:
        local = gpu_inverse_inertia(half_extents, inv_mass)
    else:
        local = true_inverse_inertia(inertia_local, inv_mass)
    world = world_inverse_inertia(orientation, local)
    world[~dynamic] = 0.0
    return compact(world, dynamic)


def inertia_product(ar: Arithmetic, inv_inertia: np.ndarray, c: np.ndarray) -> np.ndarray:
    """``I^-1 c`` in the format of ``ar``, per row.

    Diagonal (3 words): ``(Ixx cx, Iyy cy, Izz cz)``, one multiply per component. Full (6 words):
    ``((Ixx cx + Ixy cy) + Ixz cz, (Ixy cx + Iyy cy) + Iyz cz, (Ixz cx + Iyz cy) + Izz cz)``."""
    if inv_inertia.shape[-1] == 3:
        return ar.mul(inv_inertia, c)
    xx, yy, zz, xy, xz, yz = (inv_inertia[..., k] for k in range(6))
    cx, cy, cz = c[..., 0], c[..., 1], c[..., 2]
    m, a = ar.mul, ar.add
    return np.stack([a(a(m(xx, cx), m(xy, cy)), m(xz, cz)),
                     a(a(m(xy, cx), m(yy, cy)), m(yz, cz)),
                     a(a(m(xz, cx), m(yz, cy)), m(zz, cz))], axis=-1)


def quadratic_form(inv_inertia: np.ndarray, c: np.ndarray) -> np.ndarray:
    """``c^T I^-1 c`` in float64 (the host's constraint setup), rows broadcast against ``c``."""
    if inv_inertia.shape[-1] == 3:
        return np.sum(c * inv_inertia * c, axis=-1)
    xx, yy, zz, xy, xz, yz = (inv_inertia[..., k] for k in range(6))
    cx, cy, cz = c[..., 0], c[..., 1], c[..., 2]
    return (xx * cx * cx + yy * cy * cy + zz * cz * cz) + 2.0 * (xy * cx * cy + xz * cx * cz + yz * cy * cz)
