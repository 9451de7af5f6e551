"""Box2D v3's soft contact: a spring-damper form of the contact row, set up per substep on the host.

Box2D v3 (erincatto/box2d ``src/solver.c``, ``src/contact_solver.c``) solves each substep of ``h = dt / n`` as:
gravity, warm start, one *soft* solve iteration with the bias from each point's separation now, the position
update, one *relax* iteration (rigid, no push-out), and it softens a contact by a spring of ``hertz`` with a damping
ratio ``zeta``. Per contact row the soft update is

    lambda' = max(0, lambda - massScale * m_eff * (vn + bias) - impulseScale * lambda)

with, from ``omega = 2 pi hertz``, ``a1 = 2 zeta + h omega``, ``a2 = h omega a1``, ``a3 = 1 / (1 + a2)``:
``biasRate = omega / a1``, ``massScale = a2 a3``, ``impulseScale = a3``. The bias is ``s / h`` for a point still
apart (``s > 0``: speculative, solved rigid) and ``max(biasRate s, -maxPush)`` for a penetration; a relax row has no
push-out (``s / h`` apart, 0 in penetration) and is rigid. Box2D's defaults (``b2DefaultWorldDef``): contact hertz
30, capped at a quarter of the substep rate, damping ratio 10, push-out at most 3 m/s; a contact with a static body
is twice as stiff. Restitution is 0 in every hard case and is not modelled.

One deviation, measured (docs/stability.md): the static contact's hertz is capped at a quarter of the substep rate
too. Box2D's default of 4 substeps at 60 Hz keeps 2 x 30 Hz there; at 2 substeps 60 Hz is half the substep rate and
a plank carrying 25 cubes rings at 0.07 m/s.

What the kernel does and what the host does (the contract the RTL must follow, bit for bit):

* host, per call: the row's bias word ``b`` from the separation now (``soft_constraints``/``relax_constraints``,
  float64, rounded once), and the row's ``jac_inv`` word times ``massScale`` (rounded once from the format's
  ``jac_inv``): no new record word, no new kernel operation;
* kernel, per contact row (``models.golden.contact_solver.contact_solve`` with ``SolverParams.soft_keep``): one
  multiply, before the add of the accumulated impulse: ``lam' = max(lam * keep + (vrel + b) * jac_inv, 0)``, with ``keep
  = 1 - impulseScale``, a per-call constant of two values (a row with a static body, a row between two dynamic ones) and
  1 where ``b > 0`` (speculative). In exact arithmetic this is Box2D's update.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from models.setup.constraints import BodyTable, ConstraintSet
from models.formats.number_format import Arithmetic

CONTACT_HERTZ = 30.0  # b2WorldDef.contactHertz
DAMPING_RATIO = 10.0  # b2WorldDef.contactDampingRatio
MAX_PUSH = 3.0  # m/s, b2WorldDef.contactPushMaxVelocity (Box2D v3's maxBaumgarteVelocity)
STATIC_STIFFNESS = 2.0  # Box2D's staticSoftness: a contact with a static body at twice the contact hertz


@dataclass(frozen=True)
class Softness:
    """One spring-damper in Box2D's form: the bias rate (1/s) on the separation and the two scales."""

    bias_rate: float
    mass_scale: float
    impulse_scale: float

    @staticmethod
    def of(hertz: float, zeta: float, h: float) -> "Softness":
        if hertz <= 0.0:
            return Softness(0.0, 1.0, 0.0)
        omega = 2.0 * math.pi * hertz
        a1 = 2.0 * zeta + h * omega
        a2 = h * omega * a1
        a3 = 1.0 / (1.0 + a2)
        return Softness(omega / a1, a2 * a3, a3)


@dataclass(frozen=True)
class SoftContact:
    """The soft contact's settings (Box2D v3's defaults)."""

    hertz: float = CONTACT_HERTZ
    damping_ratio: float = DAMPING_RATIO
    max_push: float = MAX_PUSH
    static_stiffness: float = STATIC_STIFFNESS

    def __post_init__(self) -> None:
        if not (self.hertz >= 0.0 and self.damping_ratio >= 0.0 and self.max_push > 0.0
                and self.static_stiffness > 0.0) or not all(map(math.isfinite, (
                    self.hertz, self.damping_ratio, self.max_push, self.static_stiffness))):
            raise ValueError(f"soft contact: hertz and damping ratio must be >= 0, the push and the static "
                             f"stiffness > 0, all finite; got {self}")

    def contact_hertz(self, h: float) -> float:
        """Box2D's ``min(contactHertz, 0.25 * substep rate)``."""
        return min(self.hertz, 0.25 / h)

    def softness(self, h: float) -> tuple[Softness, Softness]:
        """(between two dynamic bodies, with a static body) for substeps of ``h``."""
        hz = self.contact_hertz(h)
        return (Softness.of(hz, self.damping_ratio, h),
                Softness.of(min(self.static_stiffness * hz, 0.25 / h), self.damping_ratio, h))

    def keep(self, h: float) -> tuple[float, float]:
        """The kernel's two per-call constants ``1 - impulseScale`` (``SolverParams.soft_keep``)."""
        dyn, static = self.softness(h)
        return 1.0 - dyn.impulse_scale, 1.0 - static.impulse_scale


def _static_rows(cons: ConstraintSet, bodies: BodyTable) -> np.ndarray:
    """(M,1) a row with a static body (inverse mass 0)."""
    return ((bodies.inv_mass[cons.body_a] == 0.0) | (bodies.inv_mass[cons.body_b] == 0.0))[:, None]


def soft_constraints(cons: ConstraintSet, separation: np.ndarray, valid: np.ndarray, bodies: BodyTable, h: float,
                     soft: SoftContact, ar: Arithmetic) -> ConstraintSet:
    """The rows of a soft solve call of ``h``: per valid point the bias from ``separation`` (m, negative:
    penetration) and ``jac_inv`` times the row's mass scale (1 where the points are apart), each rounded once."""
    dyn, static = soft.softness(h)
    on_static = _static_rows(cons, bodies)
    rate = np.where(on_static, static.bias_rate, dyn.bias_rate)
    scale = np.where(on_static, static.mass_scale, dyn.mass_scale)
    apart = separation > 0.0
    bias = np.where(apart, separation / h, np.maximum(rate * separation, -soft.max_push))
    scale = np.where(apart, 1.0, scale)
    return replace(cons, bias=ar.round(np.where(valid, bias, 0.0)),
                   jac_inv=ar.round(np.where(valid, np.asarray(cons.jac_inv, dtype=np.float64) * scale, 0.0)))


def relax_constraints(cons: ConstraintSet, separation: np.ndarray, valid: np.ndarray, h: float,
                      ar: Arithmetic) -> ConstraintSet:
    """The rows of a relax call: rigid, the bias ``s / h`` where the points are apart and 0 in penetration."""
    bias = np.where(valid & (separation > 0.0), separation / h, 0.0)
    return replace(cons, bias=ar.round(bias))


def add_gravity(bodies: BodyTable, ar: Arithmetic, gravity: tuple[float, float, float], h: float) -> BodyTable:
    """``v += g h`` on the dynamic bodies, rounded as the integrator's last operation (``models/golden/integrator.py``)."""
    out = bodies.copy()
    dyn = bodies.dynamic
    g_h = ar.mul(ar.const(np.asarray(gravity, dtype=np.float64)), ar.const(h))
    out.linear_velocity[dyn] = ar.add(bodies.linear_velocity[dyn], g_h)
    return out
