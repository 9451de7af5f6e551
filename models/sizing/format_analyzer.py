"""Number formats sized to the scene: measure what a step's values need, propose the narrowest that suffice.

Three measurements on one frame, all against the float64 step (same schedule and iterations, state after the
integration; the error is the largest of three, each relative to what the step itself changes: max |dv| over the
dynamic bodies / the largest speed, max |dx| / the largest displacement in the step, max |dq| / the largest
quaternion change; :meth:`StepProblem.error_parts`):

1. **Ranges** of every field group the kernel streams or stores (:data:`GROUPS`; impulses from the float64
   solve): smallest and largest non-zero magnitude, so the exponent width that holds them follows
   (:func:`exp_bits_for`; the thesis found its values between 3e-5 and 450).
2. **One format for the kernel** (the RTL takes one exponent/mantissa pair): the narrowest ``eXmY`` whose step
   error stays within the budget, X from the ranges, Y by bisection with the bit-accurate golden model
   (:func:`narrowest_uniform`). ``FORMAT=auto`` runs the kernel in it.
3. **A storage format per group**: each group's streamed or stored values rounded to a narrower format, the
   arithmetic in float64, the narrowest mantissa per group that keeps the error within the budget
   (:func:`storage_formats`), and then all of them together with the arithmetic in the kernel format, checked
   once more (:func:`mixed_error`). The RTL does not implement mixed storage: this part is a proposal, with the
   record bytes it would save.

The error is not strictly monotone in the mantissa width (rounding can cancel), so a bisection result is
confirmed by evaluating it; the search assumes monotonicity only to pick candidates.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Callable, Mapping

import numpy as np

from models.formats.frame import Frame
from models.order.manifold_schedule import make_schedule
from models.setup.constraints import BodyTable, ConstraintSet, body_table, setup_constraints
from models.golden.contact_solver import SolverParams, solve
from models.golden.integrator import IntegrationParams, integrate
from models.formats.number_format import FLOAT64, Arithmetic, NumberFormat
from models.sizing import mixed_layout

# field group -> (table, fields); "impulses" are computed, not streamed (the kernel keeps them on chip)
GROUPS: dict[str, tuple[str, tuple[str, ...]]] = {
    "positions": ("bodies", ("position",)),
    "orientations": ("bodies", ("orientation",)),
    "velocities": ("bodies", ("linear_velocity", "angular_velocity")),
    "mass properties": ("bodies", ("inv_mass", "inv_inertia")),
    "contact geometry": ("cons", ("normal", "points", "center", "tangent")),
    "solver coefficients": ("cons", ("jac_inv", "f_jac_inv", "bias")),
}
IMPULSES = "impulses"
MAN_RANGE = (2, 23)
HEADROOM = 4.0  # largest values times this must stay finite (sums of a few terms)


@dataclass
class GroupRange:
    group: str
    values: int
    zeros: int
    min_abs: float  # smallest non-zero magnitude
    max_abs: float
    p01_abs: float  # 0.1% quantile of the non-zero magnitudes

    @property
    def exp_bits(self) -> int:
        """Exponent bits for [0.1% quantile, max]: the rarest tiniest values may flush to zero (the error check
        on the whole step decides whether that matters)."""
        return exp_bits_for(self.p01_abs, self.max_abs)


def exp_bits_for(lo: float, hi: float) -> int:
    """Fewest exponent bits (2..10) whose normal range holds [lo, HEADROOM * hi]."""
    for e in range(2, 11):
        fmt = NumberFormat("probe", e, 10)
        if (lo == 0.0 or fmt.min_normal <= lo) and (hi == 0.0 or HEADROOM * hi < fmt.max_finite):
            return e
    return 10


def _magnitudes(arrays: list[np.ndarray]) -> np.ndarray:
    return np.abs(np.concatenate([np.asarray(a, dtype=np.float64).ravel() for a in arrays]))


def group_arrays(bodies: BodyTable, cons: ConstraintSet, group: str) -> list[np.ndarray]:
    table, fields = GROUPS[group]
    src = bodies if table == "bodies" else cons
    return [getattr(src, f) for f in fields]


def measure_ranges(bodies: BodyTable, cons: ConstraintSet, normal_impulse: np.ndarray,
                   friction_impulse: np.ndarray) -> list[GroupRange]:
    """Ranges of every group (dynamic and static bodies alike: the kernel streams both)."""
    out = []
    named = {g: group_arrays(bodies, cons, g) for g in GROUPS}
    named[IMPULSES] = [normal_impulse, friction_impulse]
    for group, arrays in named.items():
        mag = _magnitudes(arrays)
        nz = mag[mag > 0]
        lo, hi = (float(nz.min()), float(nz.max())) if nz.size else (0.0, 0.0)
        p01 = float(np.quantile(nz, 0.001)) if nz.size else 0.0
        out.append(GroupRange(group, int(mag.size), int(mag.size - nz.size), lo, hi, p01))
    return out


def round_groups(bodies: BodyTable, cons: ConstraintSet, storage: Mapping[str, NumberFormat],
                 fields_of: Mapping[str, tuple[str, tuple[str, ...]]] = GROUPS, skip: tuple[str, ...] = ()
                 ) -> tuple[BodyTable, ConstraintSet]:
    """``bodies`` and ``cons`` with each group's fields (``fields_of``: group -> table and fields, less ``skip``)
    rounded to the group's format in ``storage``."""
    for group, fmt in storage.items():
        table, all_fields = fields_of[group]
        fields = tuple(f for f in all_fields if f not in skip)
        if table == "bodies":
            bodies = dataclasses.replace(bodies, **{f: fmt.round(getattr(bodies, f)) for f in fields})
        else:
            cons = dataclasses.replace(cons, **{f: fmt.round(getattr(cons, f)) for f in fields})
    return bodies, cons


@dataclass
class StepProblem:
    """One frame's step: everything needed to solve it in any format."""

    bodies: BodyTable
    cons: ConstraintSet
    schedule: np.ndarray
    params: SolverParams
    iparams: IntegrationParams
    reference: BodyTable = dataclasses.field(init=False)  # float64 step, after integration

    def __post_init__(self) -> None:
        self.reference = self.step(FLOAT64)

    def step(self, ar: Arithmetic, storage: dict[str, NumberFormat] | None = None) -> BodyTable:
        bodies, cons = round_groups(self.bodies, self.cons, storage or {})
        solved = solve(bodies.rounded(ar), cons.rounded(ar), self.schedule, ar, self.params)
        return integrate(solved.bodies, ar, self.iparams)

    def error(self, result: BodyTable) -> float:
        """The step error: the largest of :meth:`error_parts` (a NaN counts as infinite error)."""
        return max(self.error_parts(result).values())

    def error_parts(self, result: BodyTable) -> dict[str, float]:
        """Errors of the dynamic bodies' state after the step against the float64 step, each relative to what
        the step itself changes: velocity as max |dv| / max |v|; position as max |dx| / the largest
        displacement in the step; orientation as max |dq| / the largest quaternion change in the step."""
        dyn = self.bodies.dynamic
        ref = self.reference
        pairs = {"velocity": (result.linear_velocity, ref.linear_velocity, np.zeros_like(ref.linear_velocity)),
                 "position": (result.position, ref.position, self.bodies.position),
                 "orientation": (result.orientation, ref.orientation, self.bodies.orientation)}
        out = {}
        for name, (got, want, before) in pairs.items():
            d = np.abs(got[dyn] - want[dyn])
            scale = max(float(np.abs(want[dyn] - before[dyn]).max(initial=0.0)), 1e-12)
            out[name] = float(d.max(initial=0.0)) / scale if np.all(np.isfinite(d)) else float("inf")
        return out


def narrowest_mantissa(ok: Callable[[int], bool]) -> int | None:
    """Smallest mantissa in MAN_RANGE with ok(m) (bisection, assuming rough monotonicity; confirmed)."""
    lo, hi = MAN_RANGE
    if not ok(hi):
        return None
    while lo < hi:
        mid = (lo + hi) // 2
        if ok(mid):
            hi = mid
        else:
            lo = mid + 1
    return hi


def narrowest_uniform(problem: StepProblem, exp_bits: int, budget: float) -> tuple[NumberFormat | None, float]:
    """The narrowest e{exp_bits}m{Y} whose golden step stays within ``budget``, and its error."""
    errors: dict[int, float] = {}

    def ok(m: int) -> bool:
        errors[m] = problem.error(problem.step(NumberFormat(f"e{exp_bits}m{m}", exp_bits, m)))
        return errors[m] <= budget

    m = narrowest_mantissa(ok)
    if m is None:
        return None, errors[MAN_RANGE[1]]
    return NumberFormat(f"e{exp_bits}m{m}", exp_bits, m), errors[m]


def storage_formats(problem: StepProblem, ranges: list[GroupRange], budget: float) -> dict[str, tuple[NumberFormat, float]]:
    """Per streamed group: the narrowest storage format (others exact, float64 arithmetic) within ``budget``."""
    out: dict[str, tuple[NumberFormat, float]] = {}
    by_name = {r.group: r for r in ranges}
    for group in GROUPS:
        e = by_name[group].exp_bits
        errors: dict[int, float] = {}

        def ok(m: int, group: str = group, e: int = e) -> bool:
            fmt = NumberFormat(f"e{e}m{m}", e, m)
            errors[m] = problem.error(problem.step(FLOAT64, {group: fmt}))
            return errors[m] <= budget

        m = narrowest_mantissa(ok)
        if m is not None:
            out[group] = (NumberFormat(f"e{e}m{m}", e, m), errors[m])
    return out


def mixed_error(problem: StepProblem, compute: NumberFormat, storage: dict[str, NumberFormat]) -> float:
    """The step error with every group stored in its own format and the arithmetic in ``compute``."""
    return problem.error(problem.step(compute, storage))


def fit_mixed(problem: StepProblem, compute: NumberFormat, storage: dict[str, NumberFormat],
              budget: float) -> tuple[dict[str, NumberFormat], float]:
    """Widen every group's mantissa one bit at a time until all groups together (arithmetic in ``compute``) stay
    within ``budget``: the per-group errors add up. Returns the formats and their error."""
    cur = dict(storage)
    err = mixed_error(problem, compute, cur)
    while err > budget and any(f.man_bits < MAN_RANGE[1] for f in cur.values()):
        cur = {g: NumberFormat(f"e{f.exp_bits}m{min(f.man_bits + 1, MAN_RANGE[1])}", f.exp_bits,
                               min(f.man_bits + 1, MAN_RANGE[1])) for g, f in cur.items()}
        err = mixed_error(problem, compute, cur)
    return cur, err


def record_bits(storage: Mapping[str, NumberFormat], compute: NumberFormat) -> dict[str, int]:
    """Unpadded bits of the contact, friction and body-in records of the kernel with its impulses on chip, every group
    in its storage format (``compute``'s where none is given): ``models/sizing/mixed_layout.py``'s layout."""
    rb = mixed_layout.record_bits(storage, compute, mixed_layout.RecordShape(impulses_in_records=False))
    return {"contact": rb.contact, "friction": rb.friction, "body-in": rb.body_in}


DEFAULT_BUDGET = 0.01  # FORMAT=auto: the step's relative error against float64 allowed


def problem_of(frame: Frame, iters: int) -> StepProblem:
    bodies = body_table(frame)
    cons = setup_constraints(frame, bodies)
    schedule = make_schedule("hazard", cons, bodies.dynamic, 64)
    return StepProblem(bodies, cons, schedule, SolverParams(iterations=iters),
                          IntegrationParams(dt=frame.dt, gravity=tuple(frame.gravity)))


def kernel_format(problem: StepProblem, budget: float) -> tuple[NumberFormat, float, list[GroupRange]]:
    """The narrowest single format for the kernel (FORMAT=auto), its error, and the measured ranges."""
    solved = solve(problem.bodies, problem.cons, problem.schedule, FLOAT64, problem.params)
    ranges = measure_ranges(problem.bodies, problem.cons, solved.impulses.normal, solved.impulses.friction)
    e = max(r.exp_bits for r in ranges)
    fmt, err = narrowest_uniform(problem, e, budget)
    if fmt is None:
        raise ValueError(f"no format with {e} exponent bits and up to {MAN_RANGE[1]} mantissa bits keeps the "
                         f"error within {budget:g} (best {err:.3g})")
    return fmt, err, ranges


def auto_format(frame: Frame, iters: int) -> NumberFormat:
    """FORMAT=auto: the narrowest single kernel format whose ``iters``-iteration step of ``frame`` stays within
    the default error budget; prints the choice."""
    fmt, err, _ = kernel_format(problem_of(frame, iters), DEFAULT_BUDGET)
    print(f"FORMAT=auto: {fmt.name} (step error {err:.3g} against float64, budget {DEFAULT_BUDGET})", flush=True)
    return fmt
