"""Bullet GPU's ``integrateSingleTransform`` in a fixed operation order (golden model of the kernel).

Transcendentals are defined by the algorithm the hardware uses, not by libm:

* ``sqrt`` and division are correctly rounded (the RTL uses digit-recurrence units);
* ``sin`` and ``cos`` are fixed polynomials on the limited range the integrator needs: the half angle
  x = theta * dt / 2 is at most pi/8 because theta * dt is clamped to pi/4, where
  sin(x) = x + x*(x2*(S3 + x2*(S5 + x2*S7))) and cos(x) = 1 + x2*(C2 + x2*(C4 + x2*(C6 + x2*C8)))
  (x2 = x*x, Taylor coefficients rounded to the format). Truncation error at x = pi/8: 6e-10 (sin),
  3e-11 (cos), below binary32's unit roundoff.

Per dynamic body (static bodies, inverse mass 0, are untouched):
    w      = w * damping                                    (0.99 per step)
    theta  = sqrt((wx*wx + wy*wy) + wz*wz)
    if theta * dt > MAX_ANGLE: theta = MAX_ANGLE / dt       (MAX_ANGLE = 0.25 * 3.14159254)
    x      = theta * half_dt
    s      = theta < 0.001 ? half_dt - (dt3c * theta) * theta : sin(x) / theta
    dq     = (w.x*s, w.y*s, w.z*s, cos(x))
    q'     = dq (x) q                                       (quaternion product, order in quat_mul)
    q      = q' * (1 / sqrt((q'x*q'x + q'y*q'y) + (q'z*q'z + q'w*q'w)))
    x_pos  = x_pos + v * dt
    v      = v + g_dt
with the run constants half_dt = 0.5 * dt, dt3c = ((dt * dt) * dt) * 0.020833333333, g_dt = g * dt and
MAX_ANGLE / dt computed in the format for every body, as the kernel's integration pipe computes them (the same value
each time, and the same floating-point events: ``OPERATION_ORDER.md``, "Events").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models.setup.constraints import BodyTable
from models.formats.number_format import Arithmetic

ANGULAR_DAMPING = 0.99
MAX_ANGLE = 0.25 * 3.14159254  # Bullet's BT_GPU_ANGULAR_MOTION_THRESHOLD (sic)
SMALL_ANGLE = 0.001
TAYLOR_SINC = 0.020833333333  # 1/48
SIN_COEFFS = (-1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0)
COS_COEFFS = (-1.0 / 2.0, 1.0 / 24.0, -1.0 / 720.0, 1.0 / 40320.0)


@dataclass
class IntegrationParams:
    dt: float = 1.0 / 60.0
    gravity: tuple[float, float, float] = (0.0, -9.8, 0.0)
    damping: float = ANGULAR_DAMPING


def _horner(ar: Arithmetic, x2: np.ndarray, coeffs: tuple[float, ...]) -> np.ndarray:
    """c0 + x2*(c1 + x2*(c2 + ...)) with the coefficients rounded to the format."""
    acc = ar.const(coeffs[-1]) * np.ones_like(x2)
    for c in reversed(coeffs[:-1]):
        acc = ar.add(ar.const(c), ar.mul(x2, acc))
    return acc


def sin_poly(ar: Arithmetic, x: np.ndarray, x2: np.ndarray | None = None) -> np.ndarray:
    """x + x*(x2*(S3 + x2*(S5 + x2*S7))); ``x2`` = x*x where the caller has it (the kernel computes it once for
    sin and cos)."""
    x2 = ar.mul(x, x) if x2 is None else x2
    return ar.add(x, ar.mul(x, ar.mul(x2, _horner(ar, x2, SIN_COEFFS))))


def cos_poly(ar: Arithmetic, x: np.ndarray, x2: np.ndarray | None = None) -> np.ndarray:
    """1 + x2*(C2 + x2*(C4 + x2*(C6 + x2*C8))), ``x2`` as in :func:`sin_poly`."""
    x2 = ar.mul(x, x) if x2 is None else x2
    return ar.add(ar.const(1.0), ar.mul(x2, _horner(ar, x2, COS_COEFFS)))


def quat_mul(ar: Arithmetic, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a (x) b, quaternions (x, y, z, w); Bullet's b3QuatMul."""
    ax, ay, az, aw = (a[..., i] for i in range(4))
    bx, by, bz, bw = (b[..., i] for i in range(4))
    m = ar.mul
    x = ar.add(ar.add(m(aw, bx), m(ax, bw)), ar.sub(m(ay, bz), m(az, by)))
    y = ar.add(ar.add(m(aw, by), m(ay, bw)), ar.sub(m(az, bx), m(ax, bz)))
    z = ar.add(ar.add(m(aw, bz), m(az, bw)), ar.sub(m(ax, by), m(ay, bx)))
    w = ar.sub(ar.sub(m(aw, bw), m(ax, bx)), ar.add(m(ay, by), m(az, bz)))
    return np.stack([x, y, z, w], axis=-1)


def integrate(bodies: BodyTable, ar: Arithmetic, params: IntegrationParams = IntegrationParams()) -> BodyTable:
    """Integrate every dynamic body; returns a new table (inputs already in the format)."""
    out = bodies.copy()
    dyn = np.flatnonzero(bodies.dynamic)
    if dyn.size == 0:
        return out
    # the run constants are computed for every body, as the kernel's integration pipe does (the same values)
    dt = np.full(dyn.size, ar.const(params.dt))
    half_dt = ar.mul(ar.const(0.5), dt)
    dt3c = ar.mul(ar.mul(ar.mul(dt, dt), dt), ar.const(TAYLOR_SINC))
    g_dt = ar.mul(ar.const(np.asarray(params.gravity, dtype=np.float64)), dt[:, None])
    max_angle = ar.const(MAX_ANGLE)

    w = ar.mul(bodies.angular_velocity[dyn], ar.const(params.damping))
    theta = ar.sqrt(ar.add(ar.add(ar.mul(w[:, 0], w[:, 0]), ar.mul(w[:, 1], w[:, 1])), ar.mul(w[:, 2], w[:, 2])))
    clamp = ar.mul(theta, dt) > max_angle
    theta = np.where(clamp, ar.div(max_angle, dt), theta)
    x = ar.mul(theta, half_dt)
    x2 = ar.mul(x, x)
    small = theta < ar.const(SMALL_ANGLE)
    s_small = ar.sub(half_dt, ar.mul(ar.mul(dt3c, theta), theta))
    s_large = ar.div(sin_poly(ar, x, x2), theta)
    s = np.where(small, s_small, s_large)
    dq = np.concatenate([ar.mul(w, s[:, None]), cos_poly(ar, x, x2)[:, None]], axis=1)
    q = quat_mul(ar, dq, bodies.orientation[dyn])
    norm2 = ar.add(ar.add(ar.mul(q[:, 0], q[:, 0]), ar.mul(q[:, 1], q[:, 1])),
                   ar.add(ar.mul(q[:, 2], q[:, 2]), ar.mul(q[:, 3], q[:, 3])))
    inv_norm = ar.div(ar.const(1.0), ar.sqrt(norm2))
    out.orientation[dyn] = ar.mul(q, inv_norm[:, None])
    out.angular_velocity[dyn] = w
    out.position[dyn] = ar.add(bodies.position[dyn], ar.mul(bodies.linear_velocity[dyn], dt[:, None]))
    out.linear_velocity[dyn] = ar.add(bodies.linear_velocity[dyn], g_dt)
    return out
