"""Shock propagation (Guendelman, Bridson, Fedkiw 2003, "Nonconvex rigid bodies with stacking"), off by default.

Contacts are processed in layers from the ground up, and in the last contact pass of a kernel call (the *shock*
pass) the lower body of each contact between two layers is treated as having infinite mass: its velocity is read
but not written, so the weight of a heavy upper body cannot push lighter lower bodies into the ground.

* a body's **layer** is its contact-graph distance from the static bodies (breadth-first over the manifolds from
  every body of inverse mass 0, layer 0); a body no static body reaches gets :data:`UNREACHED`;
* a manifold's **lower body** is the one of smaller layer; on a tie neither is frozen (the row is solved as usual);
  a static lower body is not flagged (a static body is never written anyway);
* the **schedule** is the given one stably sorted ground-up by (lower layer, upper layer) of each manifold (or, with a
  hazard window, each such layer pair's manifolds in the greedy hazard order: the kernel issues a pair's rows back to
  back instead of stalling on the bodies they share);
* the **shock rows**: ``jac_inv`` and ``f_jac_inv`` recomputed on the host (float64, rounded once to the format)
  with the frozen body's inverse mass and inverse inertia 0, ``-1 / K`` with K the other body's terms only.

The solver (``models.golden.contact_solver``, ``SolverParams.shock_contact`` / ``shock_friction``) reads the shock rows
and the frozen flags of a :class:`ShockConstraintSet` in the last pass of each kind it is asked to shock, and masks the
frozen body's velocity write-back there. Every other pass is today's update, bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models.setup.constraints import BodyTable, ConstraintSet
from models.setup.inertia import quadratic_form
from models.formats.number_format import Arithmetic
from models.order.manifold_schedule import hazard_order_of

UNREACHED = np.iinfo(np.int64).max // 4  # the layer of a body no static body reaches
FREEZE_NONE, FREEZE_A, FREEZE_B = 0, 1, 2


def body_layers(body_a: np.ndarray, body_b: np.ndarray, dynamic: np.ndarray) -> np.ndarray:
    """Each body's contact-graph distance from the static bodies (0 for a static body, UNREACHED where no path)."""
    n = dynamic.shape[0]
    layer = np.where(dynamic, UNREACHED, 0).astype(np.int64)
    a, b = np.asarray(body_a, dtype=np.int64), np.asarray(body_b, dtype=np.int64)
    frontier = ~dynamic
    depth = 0
    while np.any(frontier):
        depth += 1
        touch = np.zeros(n, dtype=bool)
        touch[b[frontier[a]]] = True
        touch[a[frontier[b]]] = True
        frontier = touch & (layer == UNREACHED)
        layer[frontier] = depth
    return layer


def frozen_side(body_a: np.ndarray, body_b: np.ndarray, layer: np.ndarray, dynamic: np.ndarray) -> np.ndarray:
    """Per manifold FREEZE_A / FREEZE_B (its dynamic lower body) or FREEZE_NONE (a tie, or a static lower body)."""
    la, lb = layer[body_a], layer[body_b]
    out = np.full(body_a.shape[0], FREEZE_NONE, dtype=np.int8)
    out[(la < lb) & dynamic[body_a]] = FREEZE_A
    out[(lb < la) & dynamic[body_b]] = FREEZE_B
    return out


def layer_order(schedule: np.ndarray, cons: ConstraintSet, layer: np.ndarray, dynamic: np.ndarray | None = None,
                window: int = 0) -> np.ndarray:
    """The schedule's manifolds (bubbles dropped) stably sorted ground-up by (lower layer, upper layer); with
    ``window`` > 0 each layer pair's manifolds in the greedy hazard order of that window (``dynamic``: the bodies'
    flags; bubbles within a pair), the pairs still one after the other ground-up."""
    order = np.asarray(schedule)
    order = order[order >= 0]
    la, lb = layer[cons.body_a[order]], layer[cons.body_b[order]]
    lo, hi = np.minimum(la, lb), np.maximum(la, lb)
    key = np.lexsort((hi, lo))
    order, lo, hi = order[key], lo[key], hi[key]
    if window <= 0 or order.size == 0:
        return order
    if dynamic is None:
        raise ValueError("a hazard order within the layer pairs needs the bodies' dynamic flags")
    starts = np.flatnonzero(np.r_[True, (lo[1:] != lo[:-1]) | (hi[1:] != hi[:-1])])
    groups = np.split(order, starts[1:])
    return np.concatenate([hazard_order_of(g, cons, dynamic, window) for g in groups])


def _side_terms(direction: np.ndarray, r: np.ndarray, bodies: BodyTable, body: np.ndarray,
                angular: bool = True) -> np.ndarray:
    """m^-1 + (r x d)^T I^-1 (r x d) of one side (broadcast over points when ``r`` is (M,4,3)); without
    ``angular``, m^-1 alone."""
    c = np.cross(r, direction)
    inv_i = bodies.inv_inertia[body]
    inv_m = bodies.inv_mass[body]
    if c.ndim == 3:
        inv_i, inv_m = inv_i[:, None, :], inv_m[:, None]
    return inv_m + quadratic_form(inv_i, c) if angular else inv_m + 0.0 * c[..., 0]


@dataclass
class ShockConstraintSet(ConstraintSet):
    """A ConstraintSet with its shock rows: ``frozen`` (M,) FREEZE_*, ``shock_jac_inv`` (M,4) and
    ``shock_f_jac_inv`` (M,2), values of the format (the unfrozen rows equal ``jac_inv`` / ``f_jac_inv``)."""

    frozen: np.ndarray = None  # type: ignore[assignment]
    linear: bool = False  # the shock rows also leave the upper body's angular velocity unwritten (K: m^-1 only)
    shock_jac_inv: np.ndarray = None  # type: ignore[assignment]
    shock_f_jac_inv: np.ndarray = None  # type: ignore[assignment]

    def __post_init__(self) -> None:
        super().__post_init__()
        m = self.num_manifolds
        if (self.frozen is None or self.frozen.shape != (m,) or self.shock_jac_inv is None
                or self.shock_jac_inv.shape != (m, 4) or self.shock_f_jac_inv is None
                or self.shock_f_jac_inv.shape != (m, 2)):
            raise ValueError(f"shock rows must be frozen ({m},), shock_jac_inv ({m},4), shock_f_jac_inv ({m},2)")


    def row_flags(self, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per manifold of ``idx`` in a shock pass: body A frozen, body B frozen, and a linear row (a row with a
        frozen body, of a linear shock set): the kernel's header bits, the golden model's ``_Gathered.freeze``."""
        fa, fb = self.frozen[idx] == FREEZE_A, self.frozen[idx] == FREEZE_B
        return fa, fb, (fa | fb) & self.linear


def shock_constraints(cons: ConstraintSet, bodies: BodyTable, ar: Arithmetic, layer: np.ndarray | None = None,
                      linear: bool = False) -> ShockConstraintSet:
    """``cons`` with the frozen flags and the shock rows' coefficients (float64 on the host, rounded once);
    ``linear``: a shock row moves its upper body along the normal only (no angular write, no angular K term)."""
    dyn = bodies.dynamic
    if layer is None:
        layer = body_layers(cons.body_a, cons.body_b, dyn)
    frozen = frozen_side(cons.body_a, cons.body_b, layer, dyn)
    a, b = cons.body_a, cons.body_b
    xa, xb = bodies.position[a].astype(np.float64), bodies.position[b].astype(np.float64)
    keep_a = (frozen != FREEZE_A).astype(np.float64)
    keep_b = (frozen != FREEZE_B).astype(np.float64)
    pts = cons.points.astype(np.float64)
    n = np.broadcast_to(cons.normal.astype(np.float64)[:, None, :], pts.shape)
    ang = not linear
    k = (keep_a[:, None] * _side_terms(n, pts - xa[:, None, :], bodies, a, ang)
         + keep_b[:, None] * _side_terms(n, pts - xb[:, None, :], bodies, b, ang))
    used = cons.jac_inv != 0.0
    with np.errstate(divide="ignore"):
        jac = np.where(used, -1.0 / np.where(used & (k != 0.0), k, 1.0), 0.0)
    c = cons.center.astype(np.float64)
    kt = np.stack([keep_a * _side_terms(cons.tangent[:, j].astype(np.float64), c - xa, bodies, a, ang)
                   + keep_b * _side_terms(cons.tangent[:, j].astype(np.float64), c - xb, bodies, b, ang)
                   for j in range(2)], axis=1)
    f_used = cons.f_jac_inv != 0.0
    f_jac = np.where(f_used, -1.0 / np.where(f_used & (kt != 0.0), kt, 1.0), 0.0)
    # an unfrozen row keeps its streamed words exactly
    jac = np.where((frozen == FREEZE_NONE)[:, None], cons.jac_inv, ar.round(jac))
    f_jac = np.where((frozen == FREEZE_NONE)[:, None], cons.f_jac_inv, ar.round(f_jac))
    fields = {name: getattr(cons, name) for name in cons.__dataclass_fields__ if name in ConstraintSet.__dataclass_fields__}
    return ShockConstraintSet(**fields, frozen=frozen, linear=linear, shock_jac_inv=jac, shock_f_jac_inv=f_jac)


def shock_step(cons: ConstraintSet, bodies: BodyTable, schedule: np.ndarray, ar: Arithmetic,
               linear: bool = False, window: int = 0) -> tuple[ShockConstraintSet, np.ndarray]:
    """One step's shock rows (:func:`shock_constraints`) and its schedule in the ground-up :func:`layer_order` (with
    ``window`` > 0: hazard-ordered within each layer pair), from the layers of this step's contact graph."""
    layers = body_layers(cons.body_a, cons.body_b, bodies.dynamic)
    shocked = shock_constraints(cons, bodies, ar, layers, linear)
    return shocked, layer_order(schedule, shocked, layers, bodies.dynamic, window)

