"""The reference PGS solver: Bullet's GPU contact and friction passes, in a fixed operation order.

This module *is* the golden model of the kernel. Every arithmetic operation goes through an
:class:`~models.formats.number_format.Arithmetic` (float64, or a format that rounds every result), in exactly the
order written here and in ``models/golden/OPERATION_ORDER.md``; the RTL follows the same order so that its
results are bit-identical.

The order in which manifolds are solved is an explicit schedule (an array of manifold indices; -1 is a
bubble, which changes timing only). A pass solves the manifolds one after the other in schedule order.
To run fast in numpy the pass is evaluated in *levels*: a manifold's level is one more than the highest
level of any earlier manifold (in schedule order) that shares a dynamic body with it. Manifolds of one
level share no dynamic body and each reads exactly the velocities its sequential predecessor wrote, so
evaluating level by level is bit-identical to the sequential loop (``solve_sequential`` checks that).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Optional, Sequence

import numpy as np

from models.setup.constraints import FRICTION_COEFF, BodyTable, ConstraintSet
from models.setup.inertia import inertia_product
from models.formats.number_format import Arithmetic
from models.golden.shock_propagation import FREEZE_NONE, ShockConstraintSet

SPIN_DAMP_FACTOR = 0.1

CONTACT_PASS = 0
FRICTION_PASS = 1


# --- vector helpers: the operation order of every dot and cross product ----------------------------------
def dot3(ar: Arithmetic, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(a.x*b.x + a.y*b.y) + a.z*b.z"""
    return ar.add(ar.add(ar.mul(a[..., 0], b[..., 0]), ar.mul(a[..., 1], b[..., 1])), ar.mul(a[..., 2], b[..., 2]))


def cross3(ar: Arithmetic, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(a.y*b.z - a.z*b.y, a.z*b.x - a.x*b.z, a.x*b.y - a.y*b.x)"""
    ax, ay, az = a[..., 0], a[..., 1], a[..., 2]
    bx, by, bz = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([
        ar.sub(ar.mul(ay, bz), ar.mul(az, by)),
        ar.sub(ar.mul(az, bx), ar.mul(ax, bz)),
        ar.sub(ar.mul(ax, by), ar.mul(ay, bx)),
    ], axis=-1)


def scale3(ar: Arithmetic, v: np.ndarray, s: np.ndarray) -> np.ndarray:
    """v * s per component (s broadcast over the last axis)."""
    return ar.mul(v, np.asarray(s)[..., None])


@dataclass
class SolverParams:
    iterations: int = 4
    interleaved: bool = False  # False: all contact passes, then all friction passes (Bullet GPU)
    friction_coeff: float = FRICTION_COEFF
    # Box2D's soft contact (models/golden/soft_contact.py), two per-call constants: the share of a contact row's
    # accumulated impulse its soft update keeps, 1 - impulseScale, for a row between two dynamic bodies and for a
    # row with a static body. None (the default): the rigid update, today's kernel, bit for bit.
    soft_keep: Optional[tuple[float, float]] = None
    # shock propagation (models/golden/shock_propagation.py): the last contact pass (and with shock_friction the last
    # friction pass) of the call freezes each manifold's lower body and uses the shock rows of a ShockConstraintSet.
    # False (the default): every pass is the thesis's update, bit for bit.
    shock_contact: bool = False
    shock_friction: bool = False
    # what becomes of a shock pass's impulses on its frozen rows (a row with nothing frozen keeps its own):
    # "keep" as any pass's; "drop": discarded (a velocity correction only: the friction limit reads, and the call
    # returns, those of the pass before it); "return": kept for the rest of the call (the friction limit reads them),
    # the call returns those of the pass before it
    shock_impulses: str = "keep"
    shock_passes: int = 1  # how many of the last passes of each shocked kind are shock passes (the scheme: 1)


@dataclass
class Impulses:
    """Accumulated impulses per manifold (kept on chip by the kernel), N*s."""

    normal: np.ndarray  # (M,4)
    friction: np.ndarray  # (M,2)

    @staticmethod
    def zeros(m: int) -> "Impulses":
        return Impulses(normal=np.zeros((m, 4)), friction=np.zeros((m, 2)))

    def copy(self) -> "Impulses":
        return Impulses(normal=self.normal.copy(), friction=self.friction.copy())


@dataclass
class PassRecord:
    """What one retired manifold-pass produced (the kernel's trace record)."""

    manifold: np.ndarray  # (K,) manifold indices, in retire (schedule) order
    kind: int  # CONTACT_PASS or FRICTION_PASS
    iteration: int
    impulses: np.ndarray  # (K,4) normal or (K,2) friction accumulated impulses after the update
    lin_a: np.ndarray  # (K,3) body A's velocities after the update
    ang_a: np.ndarray
    lin_b: np.ndarray
    ang_b: np.ndarray


TraceSink = Callable[[PassRecord], None]
# (kind, manifolds, their gathered bodies, the accumulated impulses) as a level of a pass is about to be solved: what
# the manifold-passes' datapath reads (models.kernel.kernel_vectors.scene_vectors)
InputSink = Callable[[int, np.ndarray, "_Gathered", "Impulses"], None]


def pass_sequence(params: SolverParams) -> list[tuple[int, int]]:
    """The (kind, iteration) of every pass in execution order."""
    if params.interleaved:
        return [(kind, it) for it in range(params.iterations) for kind in (CONTACT_PASS, FRICTION_PASS)]
    return [(CONTACT_PASS, it) for it in range(params.iterations)] + [
        (FRICTION_PASS, it) for it in range(params.iterations)]


def schedule_levels(schedule: np.ndarray, cons: ConstraintSet, dynamic: np.ndarray) -> list[np.ndarray]:
    """Split a schedule into levels of manifolds that share no dynamic body (see module docstring).

    Returns, per level, the schedule positions of its manifolds in increasing order.
    """
    order = np.asarray(schedule)
    order = order[order >= 0]
    last = np.zeros(dynamic.shape[0], dtype=np.int64)
    a_list = cons.body_a[order].tolist()
    b_list = cons.body_b[order].tolist()
    dyn = dynamic.tolist()
    levels = np.empty(order.shape[0], dtype=np.int64)
    last_l = last.tolist()
    for i, (a, b) in enumerate(zip(a_list, b_list)):
        la = last_l[a] if dyn[a] else 0
        lb = last_l[b] if dyn[b] else 0
        lvl = (la if la > lb else lb) + 1
        levels[i] = lvl
        if dyn[a]:
            last_l[a] = lvl
        if dyn[b]:
            last_l[b] = lvl
    if order.shape[0] == 0:
        return []
    sort = np.argsort(levels, kind="stable")
    bounds = np.flatnonzero(np.diff(levels[sort])) + 1
    return [order[g] for g in np.split(sort, bounds)]


class _Gathered:
    """Body state of one level's manifolds, gathered from the body table."""

    def __init__(self, bodies: BodyTable, a: np.ndarray, b: np.ndarray):
        self.xa, self.xb = bodies.position[a], bodies.position[b]
        self.va, self.vb = bodies.linear_velocity[a], bodies.linear_velocity[b]
        self.wa, self.wb = bodies.angular_velocity[a], bodies.angular_velocity[b]
        self.ma, self.mb = bodies.inv_mass[a], bodies.inv_mass[b]
        self.ia, self.ib = bodies.inv_inertia[a], bodies.inv_inertia[b]

    def freeze(self, frozen_a: np.ndarray, frozen_b: np.ndarray, linear: np.ndarray) -> None:
        """A shock pass's rows (models/golden/shock_propagation.py): the frozen body reads as a static one (inverse
        mass and inertia 0, so it is never written back), and a linear row's bodies have no inverse inertia (no
        angular write). The kernel does the same: the frozen side's mass words enter its pipe as 0, its write is
        dropped."""
        self.ma = np.where(frozen_a, 0.0, self.ma)
        self.mb = np.where(frozen_b, 0.0, self.mb)
        self.ia = np.where((frozen_a | linear)[:, None], 0.0, self.ia)
        self.ib = np.where((frozen_b | linear)[:, None], 0.0, self.ib)

    def scatter(self, bodies: BodyTable, a: np.ndarray, b: np.ndarray) -> None:
        """Write back the velocities of dynamic bodies only (static bodies are never written)."""
        da = self.ma != 0.0
        db = self.mb != 0.0
        bodies.linear_velocity[a[da]] = self.va[da]
        bodies.angular_velocity[a[da]] = self.wa[da]
        bodies.linear_velocity[b[db]] = self.vb[db]
        bodies.angular_velocity[b[db]] = self.wb[db]


def _apply(ar: Arithmetic, g: _Gathered, lin_a: np.ndarray, ang_a: np.ndarray, lin_b: np.ndarray,
           ang_b: np.ndarray, delta: np.ndarray, mask: Optional[np.ndarray] = None) -> None:
    """v_A += lin_a*d, w_A += ang_a*d, v_B -= lin_b*d, w_B -= ang_b*d (only where mask)."""
    va = ar.add(g.va, scale3(ar, lin_a, delta))
    wa = ar.add(g.wa, scale3(ar, ang_a, delta))
    vb = ar.sub(g.vb, scale3(ar, lin_b, delta))
    wb = ar.sub(g.wb, scale3(ar, ang_b, delta))
    if mask is None:
        g.va, g.wa, g.vb, g.wb = va, wa, vb, wb
    else:
        m = mask[:, None]
        g.va, g.wa = np.where(m, va, g.va), np.where(m, wa, g.wa)
        g.vb, g.wb = np.where(m, vb, g.vb), np.where(m, wb, g.wb)


def _row_keep(keep: tuple[np.ndarray, np.ndarray], bias: np.ndarray, g: _Gathered) -> np.ndarray:
    """The soft update's keep factor of each row: 1 for a speculative row (bias > 0: the points are apart, Box2D
    solves them rigid), else the per-call constant of a row with a static body or of one between two dynamic
    bodies (a multiply by 1 is exact: a speculative row's update is the rigid one, bit for bit)."""
    static = (g.ma == 0.0) | (g.mb == 0.0)
    return np.where(bias > 0.0, np.ones_like(bias), np.where(static, keep[1], keep[0]))


def contact_solve(ar: Arithmetic, g: _Gathered, cons: ConstraintSet, idx: np.ndarray, lam: np.ndarray,
                  soft_keep: Optional[tuple[float, float]] = None, jac_inv: Optional[np.ndarray] = None) -> np.ndarray:
    """One contact pass over manifolds ``idx`` (vectorized); returns the new accumulated impulses (K,4).

    Per point i (skipped when jac_inv[i] == 0), in order i = 0..3, using the velocities the previous
    point wrote:
        rA = p - xA ; rB = p - xB ; cA = rA x n ; cB = rB x n
        vrel  = (n.vA - n.vB) + (cA.wA - cB.wB)
        delta = (vrel + b) * jac_inv
        lam'  = max(lam + delta, 0) ; delta = lam' - lam
        vA += (mA n) delta ; wA += (IA cA) delta ; vB -= (mB n) delta ; wB -= (IB cB) delta
    (IA cA: models.setup.inertia.inertia_product, a per-component product for a diagonal, the symmetric 3x3 otherwise)

    With ``soft_keep`` (Box2D's soft contact, models/golden/soft_contact.py) one multiply is added, before the add:
        lam'  = max(lam * keep + delta, 0) ; delta = lam' - lam
    keep = 1 - impulseScale, a per-call constant (``_row_keep``: 1 where b > 0); the mass scale is in the row's
    jac_inv and the soft bias in its b, both set by the host per call.

    A shock pass (models/golden/shock_propagation.py) gives its rows' ``jac_inv`` (the frozen body's inverse mass and
    inertia 0) and gathers the frozen body as a static one (``_Gathered.freeze``): read as above, never written.
    """
    jac_all = cons.jac_inv if jac_inv is None else jac_inv
    keep = None if soft_keep is None else (ar.const(soft_keep[0]), ar.const(soft_keep[1]))
    n = cons.normal[idx]
    lam = lam.copy()
    lin_a = scale3(ar, n, g.ma)
    lin_b = scale3(ar, n, g.mb)
    zero = ar.const(0.0)
    for i in range(4):
        jac = jac_all[idx, i]
        active = jac != 0.0  # every point is computed, as the kernel's pipe does, and kept where active
        p = cons.points[idx, i]
        ca = cross3(ar, ar.sub(p, g.xa), n)
        cb = cross3(ar, ar.sub(p, g.xb), n)
        vrel = ar.add(ar.sub(dot3(ar, n, g.va), dot3(ar, n, g.vb)), ar.sub(dot3(ar, ca, g.wa), dot3(ar, cb, g.wb)))
        delta = ar.mul(ar.add(vrel, cons.bias[idx, i]), jac)
        start = lam[:, i] if keep is None else ar.mul(lam[:, i], _row_keep(keep, cons.bias[idx, i], g))
        new = ar.max(ar.add(start, delta), zero)
        delta = ar.sub(new, lam[:, i])
        lam[:, i] = np.where(active, new, lam[:, i])
        _apply(ar, g, lin_a, inertia_product(ar, g.ia, ca), lin_b, inertia_product(ar, g.ib, cb), delta, active)
    return lam


def friction_solve(ar: Arithmetic, g: _Gathered, cons: ConstraintSet, idx: np.ndarray, lam_n: np.ndarray,
                   lam_t: np.ndarray, friction_coeff: float, f_jac_inv: Optional[np.ndarray] = None,
                   no_spin: Optional[np.ndarray] = None) -> np.ndarray:
    """One friction pass over manifolds ``idx``; returns the new friction impulses (K,2).

        limit = mu * ((lam0 + lam1) + (lam2 + lam3))           (mu = friction_coeff, Bullet GPU's 0.7, or the
                                                                 manifold's own where cons.friction holds it)
        rA = c - xA ; rB = c - xB
        for j in 0, 1 (tangent t_j = planeSpace(-n)[j]):
            cA = rA x t ; cB = rB x t
            u     = (t.vA - t.vB) + (cA.wA - cB.wB)
            delta = (-u) * f_jac_inv[j]
            lam'  = min(max(lam + delta, -limit), limit) ; delta = lam' - lam
            vA -= (mA t) delta ; wA -= (IA cA) delta ; vB += (mB t) delta ; wB += (IB cB) delta
        if spin_damp:  wA -= ((n.wA) * 0.1) n ; wB -= ((n.wB) * 0.1) n
    A manifold whose f_jac_inv[0] is 0 is skipped entirely (Bullet's early return). A shock pass gives its rows'
    ``f_jac_inv``, gathers each frozen body as a static one (``_Gathered.freeze``: never written, its spin damping
    included) and ``no_spin``: the linear shock rows, whose bodies are not spin-damped either.
    """
    f_jac = cons.f_jac_inv if f_jac_inv is None else f_jac_inv
    lam_t = lam_t.copy()
    active = f_jac[idx, 0] != 0.0  # the row the kernel reads (a shock pass: its shock row)
    ln = lam_n[idx]
    mu = cons.friction[idx, 0] if cons.per_manifold_friction else ar.const(friction_coeff)
    limit = ar.mul(mu, ar.add(ar.add(ln[:, 0], ln[:, 1]), ar.add(ln[:, 2], ln[:, 3])))
    neg_limit = -limit
    c = cons.center[idx]
    ra = ar.sub(c, g.xa)
    rb = ar.sub(c, g.xb)
    for j in range(2):
        t = cons.tangent[idx, j]
        ca = cross3(ar, ra, t)
        cb = cross3(ar, rb, t)
        u = ar.add(ar.sub(dot3(ar, t, g.va), dot3(ar, t, g.vb)), ar.sub(dot3(ar, ca, g.wa), dot3(ar, cb, g.wb)))
        delta = ar.mul(-u, f_jac[idx, j])
        new = ar.min(ar.max(ar.add(lam_t[:, j], delta), neg_limit), limit)
        delta = ar.sub(new, lam_t[:, j])
        lam_t[:, j] = np.where(active, new, lam_t[:, j])
        # the friction impulse acts along -t on A and +t on B: negate delta and reuse _apply's signs
        _apply(ar, g, scale3(ar, t, g.ma), inertia_product(ar, g.ia, ca), scale3(ar, t, g.mb),
               inertia_product(ar, g.ib, cb), -delta, active)
    # the damped spin of every manifold is computed, as the kernel's pipe does, and kept where damped
    damp = active & cons.spin_damp[idx] & (True if no_spin is None else ~no_spin)
    n = cons.normal[idx]
    k = ar.const(SPIN_DAMP_FACTOR)
    wa = ar.sub(g.wa, scale3(ar, n, ar.mul(dot3(ar, n, g.wa), k)))
    wb = ar.sub(g.wb, scale3(ar, n, ar.mul(dot3(ar, n, g.wb), k)))
    g.wa = np.where(damp[:, None], wa, g.wa)
    g.wb = np.where(damp[:, None], wb, g.wb)
    return lam_t


@dataclass
class SolveResult:
    bodies: BodyTable
    impulses: Impulses
    levels: int = 0
    records: list[PassRecord] = field(default_factory=list)
    rejected_passes: int = 0  # manifold-passes skipped by the record check (``solve``'s ``record_checks``)


def solve(bodies: BodyTable, cons: ConstraintSet, schedule: np.ndarray, ar: Arithmetic,
          params: SolverParams = SolverParams(), trace: Optional[TraceSink] = None,
          levels: Optional[list[np.ndarray]] = None, initial: Optional[Impulses] = None,
          record_checks: Optional[Sequence[bool]] = None, inputs: Optional[InputSink] = None) -> SolveResult:
    """All passes of one step over ``schedule`` (level-vectorized, bit-identical to sequential order).

    ``bodies`` and ``cons`` must already hold values of the arithmetic's format (``.rounded(ar)``).
    Only velocities change; positions and orientations are integrated separately. ``initial`` holds the
    accumulated impulses the first pass of each kind starts from (zeros when None, as Bullet's GPU solver
    does; a warm start otherwise, already rounded to the format and already applied to the velocities).
    ``record_checks`` (one flag per pass of ``pass_sequence``; None: no check) is the kernel whose impulses travel
    with the records (``KernelJob.record_checks``): at a flagged friction pass a manifold whose record carries a
    non-finite impulse word is rejected for the rest of the step (``run_pass``). ``inputs`` sees every level of
    every pass before it is solved (``run_pass``).
    """
    out = bodies.copy()
    imp = Impulses.zeros(cons.num_manifolds) if initial is None else initial.copy()
    passes = pass_sequence(params)
    if record_checks is not None and len(record_checks) != len(passes):
        raise ValueError(f"record_checks has {len(record_checks)} flags for {len(passes)} passes")
    rejected = None if record_checks is None else np.zeros(cons.num_manifolds, dtype=bool)
    skipped = 0
    if imp.normal.shape != (cons.num_manifolds, 4) or imp.friction.shape != (cons.num_manifolds, 2):
        raise ValueError(f"initial impulses must be ({cons.num_manifolds},4) and ({cons.num_manifolds},2), got "
                         f"{imp.normal.shape} and {imp.friction.shape}")
    if (params.shock_contact or params.shock_friction) and not isinstance(cons, ShockConstraintSet):
        raise ValueError("a shock pass needs the shock rows: models.golden.shock_propagation.shock_constraints")
    if params.shock_impulses not in SHOCK_IMPULSES:
        raise ValueError(f"shock_impulses must be one of {', '.join(SHOCK_IMPULSES)}, got {params.shock_impulses!r}")
    if levels is None:
        levels = schedule_levels(schedule, cons, bodies.dynamic)
    before: Optional[Impulses] = None  # "return": the impulses before the first shock pass
    for p, (kind, it) in enumerate(passes):
        if before is None and params.shock_impulses == "return" and is_shock_pass(params, kind, it):
            before = imp.copy()
        skipped += run_pass(out, imp, cons, levels, ar, kind, it, params, schedule, trace, rejected,
                            record_checks is not None and bool(record_checks[p]), inputs)
    if before is not None:
        assert isinstance(cons, ShockConstraintSet)
        rows = cons.frozen != FREEZE_NONE
        imp.normal[rows] = before.normal[rows] if params.shock_contact else imp.normal[rows]
        imp.friction[rows] = before.friction[rows] if params.shock_friction else imp.friction[rows]
    return SolveResult(bodies=out, impulses=imp, levels=len(levels), rejected_passes=skipped)


SHOCK_IMPULSES = ("keep", "drop", "return")


def is_shock_pass(params: SolverParams, kind: int, iteration: int) -> bool:
    """The last ``shock_passes`` passes of a shocked kind (models/golden/shock_propagation.py)."""
    return iteration >= params.iterations - params.shock_passes and (
        params.shock_contact if kind == CONTACT_PASS else params.shock_friction)


def run_pass(out: BodyTable, imp: Impulses, cons: ConstraintSet, levels: list[np.ndarray], ar: Arithmetic, kind: int,
             iteration: int, params: SolverParams, schedule: np.ndarray, trace: Optional[TraceSink] = None,
             rejected: Optional[np.ndarray] = None, check: bool = False, inputs: Optional[InputSink] = None) -> int:
    """One pass of ``kind`` over all manifolds, updating ``out``'s velocities and ``imp`` in place.

    ``rejected`` ((M,) bool, updated in place; None: every manifold is solved) holds the manifolds the kernel
    rejects: they are skipped (no update, no trace record). With ``check`` the pass reads its records with the
    impulse words they carry as it starts (the kernel whose impulses travel with the records), and in a friction
    pass a manifold with a non-finite lam[0..3] or lamT[0..1] joins ``rejected`` (error 5; a rejected slot stays
    rejected for the rest of the step). The kernel checks a friction record's words with the impulses it carries,
    a contact record's 23 words without its 4 impulse words (``rtl/README.md``, error 5), so a contact pass takes
    a non-finite lam into its pipe. ``inputs`` sees each level's manifolds (those not rejected), their gathered
    bodies (before a shock pass freezes some) and the impulses, before they are solved. Returns the
    manifold-passes skipped."""
    pass_records: list[PassRecord] = []
    shock = is_shock_pass(params, kind, iteration)
    skipped = 0
    for idx in levels:
        if rejected is not None:
            if check and kind == FRICTION_PASS:
                carried = np.concatenate([imp.normal[idx], imp.friction[idx]], axis=1)
                rejected[idx] |= ~np.all(np.isfinite(carried), axis=1)
            skipped += int(np.count_nonzero(rejected[idx]))
            idx = idx[~rejected[idx]]
            if idx.size == 0:
                continue
        a, b = cons.body_a[idx], cons.body_b[idx]
        g = _Gathered(out, a, b)
        if inputs is not None:
            inputs(kind, idx, g, imp)
        frozen: Optional[np.ndarray] = None  # a shock pass: the rows with a frozen body
        linear: Optional[np.ndarray] = None
        if shock:
            assert isinstance(cons, ShockConstraintSet)
            fa, fb, linear = cons.row_flags(idx)
            frozen = fa | fb
            g.freeze(fa, fb, linear)
        held = imp.normal if kind == CONTACT_PASS else imp.friction  # the pass kind's accumulated impulses
        if kind == CONTACT_PASS:
            new_imp = contact_solve(ar, g, cons, idx, held[idx], params.soft_keep,
                                    cons.shock_jac_inv if shock else None)
        else:
            new_imp = friction_solve(ar, g, cons, idx, imp.normal, held[idx], params.friction_coeff,
                                     cons.shock_f_jac_inv if shock else None, linear)
        if frozen is not None and params.shock_impulses == "drop":  # the frozen rows keep what they held
            new_imp = np.where(frozen[:, None], held[idx], new_imp)
        held[idx] = new_imp
        g.scatter(out, a, b)
        if trace is not None:
            pass_records.append(PassRecord(idx, kind, iteration, new_imp, g.va, g.wa, g.vb, g.wb))
    if trace is not None and pass_records:
        trace(_in_schedule_order(pass_records, schedule))
    return skipped


@dataclass
class ConvergedResult:
    """A solve run until a pass no longer changes the velocities (see :func:`solve_converged`)."""

    result: SolveResult
    contact_passes: int
    friction_passes: int
    last_change: float  # max |dv|, |dw| of the last pass (m/s, rad/s)
    converged: bool
    # per kind (contact, friction): the passes still needed at the rate of the last RATE_WINDOW passes (0: converged;
    # inf: no progress over the window; nan: stopped before a window's rate was known)
    projected: tuple[float, float] = (0.0, 0.0)


RATE_WINDOW = 250  # passes over which solve_converged measures the rate at which the per-pass change falls


def solve_converged(bodies: BodyTable, cons: ConstraintSet, schedule: np.ndarray, ar: Arithmetic,
                    tolerance: float = 1e-9, max_passes: int = 1000, time_budget_s: float | None = None,
                    params: SolverParams = SolverParams(), hopeless_after: int = 1000) -> ConvergedResult:
    """The limit of the GPU scheme (contact passes, then friction passes) as the iteration count grows.

    Contact passes run until one changes no velocity by more than ``tolerance`` (or ``max_passes``, or the
    time budget, spent evenly between the two kinds), then friction passes likewise. With a time budget a kind
    also stops, once past ``hopeless_after`` passes, when the rate of the last RATE_WINDOW passes says it cannot reach
    ``tolerance`` within its share (``projected``: the passes it would still need; ``make sim`` lifts max_passes
    and keeps the former cap of 1,000 as ``hopeless_after``, so its iterate is never one of fewer passes than
    before). ``converged`` is False when a limit stopped either loop first.
    """
    import time

    t0 = time.monotonic()
    out = bodies.copy()
    imp = Impulses.zeros(cons.num_manifolds)
    levels = schedule_levels(schedule, cons, bodies.dynamic)
    counts: list[int] = []
    projected: list[float] = []
    change = 0.0
    converged = True
    for k, kind in enumerate((CONTACT_PASS, FRICTION_PASS)):
        n, change = 0, np.inf
        history: list[float] = []
        need = float("nan")
        start = time.monotonic()
        deadline = None if time_budget_s is None else t0 + time_budget_s * (k + 1) / 2
        while change > tolerance and n < max_passes and (deadline is None or time.monotonic() < deadline):
            v0, w0 = out.linear_velocity.copy(), out.angular_velocity.copy()
            run_pass(out, imp, cons, levels, ar, kind, n, params, schedule)
            change = float(max(np.abs(out.linear_velocity - v0).max(initial=0.0),
                               np.abs(out.angular_velocity - w0).max(initial=0.0)))
            n += 1
            history.append(change)
            if n % RATE_WINDOW == 0 and change > tolerance:
                need = _passes_needed(history[-RATE_WINDOW - 1] if n > RATE_WINDOW else history[0], change,
                                      RATE_WINDOW if n > RATE_WINDOW else RATE_WINDOW - 1, tolerance)
                if deadline is not None and n >= hopeless_after:
                    left = (deadline - time.monotonic()) / ((time.monotonic() - start) / n)
                    if need > min(left, max_passes - n):
                        break
        converged = converged and change <= tolerance
        counts.append(n)
        projected.append(0.0 if change <= tolerance else need)
    return ConvergedResult(SolveResult(out, imp, len(levels)), counts[0], counts[1], change, converged,
                           (projected[0], projected[1]))


def _passes_needed(before: float, now: float, passes: int, tolerance: float) -> float:
    """Passes until the per-pass change reaches ``tolerance`` if it keeps falling geometrically as it fell from
    ``before`` to ``now`` over ``passes`` passes (inf: it did not fall)."""
    if not (0.0 < now < before):
        return float("inf")
    rate = (now / before) ** (1.0 / passes)
    return float(np.log(tolerance / now) / np.log(rate))


def _in_schedule_order(records: list[PassRecord], schedule: np.ndarray) -> PassRecord:
    """Merge one pass's level records back into schedule (retire) order."""
    manifold = np.concatenate([r.manifold for r in records])
    pos = np.empty(int(schedule.max()) + 1 if schedule.size else 0, dtype=np.int64)
    sched = schedule[schedule >= 0]
    pos[sched] = np.arange(sched.shape[0])
    order = np.argsort(pos[manifold], kind="stable")
    cat = lambda name: np.concatenate([getattr(r, name) for r in records])[order]  # noqa: E731
    first = records[0]
    return PassRecord(manifold[order], first.kind, first.iteration, cat("impulses"), cat("lin_a"), cat("ang_a"),
                      cat("lin_b"), cat("ang_b"))


def solve_sequential(bodies: BodyTable, cons: ConstraintSet, schedule: np.ndarray, ar: Arithmetic,
                     params: SolverParams = SolverParams()) -> SolveResult:
    """The plain one-manifold-at-a-time loop: the definition that ``solve`` must reproduce bit for bit."""
    levels = [np.array([m]) for m in np.asarray(schedule) if m >= 0]
    return solve(bodies, cons, schedule, ar, params, levels=levels)
