"""The friction tangent basis derived from the normal in the kernel's number format (the record layout option
``tangents_on_chip`` of ``models/kernel/stream_format.py``): Bullet's ``btPlaneSpace1`` of -n, as the friction pipe
``pgs_friction_pipe_tb`` computes it (``rtl/gen/kernel_graphs.py``, the same operations in the same order), so the
friction record need not carry t0 and t1 (6 words: the fp32 friction record with impulses 704 -> 512 bits, one
512-bit beat).

With m = -n (a sign flip, exact), C = 0.70710678 rounded to the format:

    use_z = C < max(m_z, -m_z)
    a_z = m_y m_y + m_z m_z ;  k_z = 1 / sqrt(use_z ? a_z : 1)
    p_z = (0, -m_z k_z, m_y k_z) ;  q_z = (a_z k_z, -m_x p_z.z, m_x p_z.y)
    a_x = m_x m_x + m_y m_y ;  k_x = 1 / sqrt(use_z ? 1 : a_x)
    p_x = (-m_y k_x, m_x k_x, 0) ;  q_x = (-m_z p_x.y, m_z p_x.x, a_x k_x)
    t0 = use_z ? p_z : p_x ;  t1 = use_z ? q_z : q_x

every operation rounded to the format (the square root and the division each once). The host's float64
``models.setup.constraints.plane_space`` is the same formula without the roundings; the solve's f_jac_inv stays the
host's (float64 tangents).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from models.setup.constraints import ConstraintSet
from models.formats.number_format import Arithmetic

PLANE_SPACE_SPLIT = 0.70710678  # models.setup.constraints.plane_space's |n_z| threshold (Bullet's SIMDSQRT12)


def plane_space_in(ar: Arithmetic, n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(t0, t1), each (K, 3), of the normals ``n`` (K, 3), values of ``ar``'s format: ``plane_space(-n)`` in
    ``ar``'s arithmetic (the module docstring's operation order)."""
    m = -np.asarray(n, dtype=np.float64)
    mx, my, mz = m[:, 0], m[:, 1], m[:, 2]
    one, zero = ar.const(1.0) * np.ones_like(mx), np.zeros_like(mx)
    use_z = ar.const(PLANE_SPACE_SPLIT) < ar.max(mz, -mz)
    my2 = ar.mul(my, my)  # one product for a_z and a_x, as the pipe computes it (and counts its events once)
    a_z = ar.add(my2, ar.mul(mz, mz))
    k_z = ar.div(one, ar.sqrt(np.where(use_z, a_z, one)))
    pz = np.stack([zero, ar.mul(-mz, k_z), ar.mul(my, k_z)], axis=1)
    qz = np.stack([ar.mul(a_z, k_z), ar.mul(-mx, pz[:, 2]), ar.mul(mx, pz[:, 1])], axis=1)
    a_x = ar.add(ar.mul(mx, mx), my2)
    k_x = ar.div(one, ar.sqrt(np.where(use_z, one, a_x)))
    px = np.stack([ar.mul(-my, k_x), ar.mul(mx, k_x), zero], axis=1)
    qx = np.stack([ar.mul(-mz, px[:, 1]), ar.mul(mz, px[:, 0]), ar.mul(a_x, k_x)], axis=1)
    sel = use_z[:, None]
    return np.where(sel, pz, px), np.where(sel, qz, qx)


def derive_tangents(cons: ConstraintSet, ar: Arithmetic) -> ConstraintSet:
    """``cons`` (already rounded to ``ar``'s format) with the tangents the kernel derives from its normals."""
    if cons.num_manifolds == 0:
        return cons
    with np.errstate(all="ignore"):
        t0, t1 = plane_space_in(ar, cons.normal)
    return dataclasses.replace(cons, tangent=np.stack([t0, t1], axis=1))
