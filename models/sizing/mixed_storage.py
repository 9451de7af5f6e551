"""Mixed storage with the arithmetic in the kernel's format: the golden step whose streamed and stored values are
rounded to a format per field group, the error budget "within ``factor`` times the kernel format's own rounding
error", and the narrowest storage per group within it.

What is stored, and so rounded (the arithmetic, the body RAM and every intermediate stay in the kernel's format):

* the records' fields (contact geometry, solver coefficients; the friction coefficient with the coefficients) and
  the body-in record's (positions, orientations, velocities, mass properties), once, as they are streamed in;
* with the impulses in the records, the impulses: every pass reads the impulses its predecessor wrote back to the
  DDR in the stored format, so they are rounded to it after every pass (a manifold appears once per pass);
* the body-out record: positions, orientations and velocities after the integration, in their groups' formats.

With the tangents derived on chip (``tangents_on_chip``) the friction record carries no t0, t1: the kernel derives
them in its arithmetic from the stored normal (``models/setup/tangent_basis.py``), as ``KernelJob.tangents_derived``.

The error of a step is measured as ``make sim`` reports the rounding error: absolute max |dv| (m/s), |dw|
(rad/s) over the dynamic bodies against the float64 step of the same schedule, and beside them max |dx| (m) and
|dq| of positions and orientations. The budget (:class:`Budget`) is ``factor`` (10) times each of those of the
kernel format's own step with nothing else narrowed; a step is within it when every gated part is
(:meth:`Budget.ratio` <= 1). The search (:func:`search_storage`) is ``models/sizing/format_analyzer.py``'s: each group
alone in float64 arithmetic, the narrowest mantissa within the budget (bisection, confirmed), then all together in
the kernel's arithmetic, every group one bit wider until the step is within the budget; a format at least as wide
as the kernel's is the kernel's (no converter).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from models.sizing import format_analyzer as fa
from models.setup.constraints import BodyTable, ConstraintSet
from models.golden.contact_solver import Impulses, SolverParams, pass_sequence, run_pass, schedule_levels, solve
from models.golden.integrator import integrate
from models.sizing.mixed_layout import IMPULSES, ORIENTATIONS, POSITIONS, STORED_GROUPS, VELOCITIES
from models.formats.number_format import FLOAT64, Arithmetic, NumberFormat
from models.setup.tangent_basis import derive_tangents

DEFAULT_FACTOR = 10.0
STATE_PARTS = ("dv", "dw", "dx", "dq")
# stored fields of each group (format_analyzer's groups; the per-manifold friction coefficient with the
# coefficients); impulses are rounded per pass, not here
FIELDS: dict[str, tuple[str, tuple[str, ...]]] = {
    **fa.GROUPS, "solver coefficients": ("cons", fa.GROUPS["solver coefficients"][1] + ("friction",))}
BODY_OUT_FIELDS = {POSITIONS: ("position",), ORIENTATIONS: ("orientation",),
                   VELOCITIES: ("linear_velocity", "angular_velocity")}


@dataclass(frozen=True)
class StateError:
    """Absolute max differences over the dynamic bodies: velocity (m/s), angular velocity (rad/s), position (m),
    orientation (quaternion components)."""

    dv: float
    dw: float
    dx: float
    dq: float

    @staticmethod
    def between(got: BodyTable, ref: BodyTable, dynamic: np.ndarray) -> "StateError":
        def worst(field: str) -> float:
            d = np.abs(getattr(got, field)[dynamic] - getattr(ref, field)[dynamic])
            return float(d.max(initial=0.0)) if np.all(np.isfinite(d)) else float("inf")

        return StateError(worst("linear_velocity"), worst("angular_velocity"), worst("position"),
                          worst("orientation"))

    def scaled(self, k: float) -> "StateError":
        return StateError(self.dv * k, self.dw * k, self.dx * k, self.dq * k)

    def as_dict(self) -> dict[str, float]:
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class Budget:
    """``factor`` times the kernel format's own rounding error, per gated part of the state."""

    own: StateError  # the kernel format's step against float64, nothing else narrowed
    factor: float = DEFAULT_FACTOR
    parts: tuple[str, ...] = STATE_PARTS

    def __post_init__(self) -> None:
        if not self.factor > 0 or not set(self.parts) <= set(STATE_PARTS) or not self.parts:
            raise ValueError(f"budget factor must be > 0 and parts a non-empty subset of {STATE_PARTS}, got "
                             f"{self.factor}, {self.parts}")

    @property
    def limits(self) -> StateError:
        return self.own.scaled(self.factor)

    def ratio(self, err: StateError) -> float:
        """The largest gated part over its limit (1.0: at the budget; a zero limit counts only a non-zero error)."""
        lim, got = self.limits.as_dict(), err.as_dict()
        return max((got[p] / lim[p]) if lim[p] > 0 else (0.0 if got[p] == 0 else float("inf")) for p in self.parts)


def solve_stored_impulses(bodies: BodyTable, cons: ConstraintSet, schedule: np.ndarray, ar: Arithmetic,
                          params: SolverParams, stored: NumberFormat) -> BodyTable:
    """:func:`models.golden.contact_solver.solve` with the impulses written back in ``stored`` after every pass (each
    pass reads what its predecessor stored); the velocities after the step."""
    out = bodies.copy()
    imp = Impulses.zeros(cons.num_manifolds)
    levels = schedule_levels(schedule, cons, bodies.dynamic)
    for kind, it in pass_sequence(params):
        run_pass(out, imp, cons, levels, ar, kind, it, params, schedule)
        imp.normal, imp.friction = ar.round(stored.round(imp.normal)), ar.round(stored.round(imp.friction))
    return out


@dataclass
class MixedStepProblem(fa.StepProblem):
    """A frame's step with mixed storage (:meth:`step`) and the budgeted error (:meth:`error`: the budget ratio
    once :attr:`budget` is set, else ``format_analyzer``'s relative error)."""

    budget: Budget | None = None
    tangents_on_chip: bool = False  # the kernel derives t0, t1 from the stored normal in its arithmetic

    def step(self, ar: Arithmetic, storage: Mapping[str, NumberFormat] | None = None) -> BodyTable:
        storage = dict(storage or {})
        unknown = sorted(set(storage) - set(STORED_GROUPS))
        if unknown:
            raise ValueError(f"unknown field groups {unknown} (groups: {', '.join(STORED_GROUPS)})")
        bodies, cons = fa.round_groups(self.bodies, self.cons, {g: f for g, f in storage.items() if g != IMPULSES},
                                       FIELDS, ("tangent",) if self.tangents_on_chip else ())
        bodies, cons = bodies.rounded(ar), cons.rounded(ar)
        if self.tangents_on_chip and isinstance(ar, NumberFormat):  # float64: the frame's planeSpace tangents
            cons = derive_tangents(cons, ar)
        if IMPULSES in storage:
            solved = solve_stored_impulses(bodies, cons, self.schedule, ar, self.params, storage[IMPULSES])
        else:
            solved = solve(bodies, cons, self.schedule, ar, self.params).bodies
        final = integrate(solved, ar, self.iparams)
        out = {f: storage[g].round(getattr(final, f)) for g, fs in BODY_OUT_FIELDS.items() if g in storage
               for f in fs}
        return dataclasses.replace(final, **out) if out else final

    def state_error(self, result: BodyTable) -> StateError:
        return StateError.between(result, self.reference, self.bodies.dynamic)

    def error(self, result: BodyTable) -> float:
        if self.budget is None:
            return super().error(result)
        return self.budget.ratio(self.state_error(result))


def capped(storage: Mapping[str, NumberFormat], compute: NumberFormat) -> dict[str, NumberFormat]:
    """The groups whose storage is narrower than the kernel's format (a wider one gains nothing: the arithmetic
    rounds it to the kernel's format)."""
    return {g: f for g, f in storage.items() if f.width < compute.width}


@dataclass(frozen=True)
class StorageSearch:
    """The search's result: each group alone (float64 arithmetic) and all together (the kernel's arithmetic)."""

    alone: dict[str, tuple[NumberFormat, float]]  # group -> narrowest format alone and its budget ratio
    chosen: dict[str, NumberFormat]  # narrower than the kernel's format, all together within the budget
    ratio: float  # the chosen storage's budget ratio with the kernel's arithmetic


def narrowest_alone(problem: MixedStepProblem, group: str, exp_bits: int, compute: NumberFormat
                    ) -> tuple[NumberFormat, float] | None:
    """The narrowest ``eXmY`` for ``group`` alone (float64 arithmetic) within the budget: X from the group's
    range, one bit more each time no mantissa suffices (the rarest tiniest values the range lets flush matter
    at a tight budget), up to the kernel format's exponent; None where none does."""
    for e in range(exp_bits, max(exp_bits, compute.exp_bits) + 1):
        ratios: dict[int, float] = {}

        def ok(m: int, e: int = e) -> bool:
            ratios[m] = problem.error(problem.step(FLOAT64, {group: NumberFormat(f"e{e}m{m}", e, m)}))
            return ratios[m] <= 1.0

        m = fa.narrowest_mantissa(ok)
        if m is not None:
            return NumberFormat(f"e{e}m{m}", e, m), ratios[m]
    return None


def search_storage(problem: MixedStepProblem, compute: NumberFormat) -> StorageSearch:
    """The narrowest storage per group within ``problem.budget`` (see the module docstring)."""
    if problem.budget is None:
        raise ValueError("search_storage needs the problem's budget (MixedStepProblem.budget)")
    solved = solve(problem.bodies, problem.cons, problem.schedule, FLOAT64, problem.params)
    ranges = {r.group: r for r in fa.measure_ranges(problem.bodies, problem.cons, solved.impulses.normal,
                                                     solved.impulses.friction)}
    alone = {g: found for g in STORED_GROUPS
             if (found := narrowest_alone(problem, g, ranges[g].exp_bits, compute)) is not None}
    chosen, ratio = fa.fit_mixed(problem, compute, capped({g: f for g, (f, _) in alone.items()}, compute), 1.0)
    narrow = capped(chosen, compute)
    if narrow != chosen:
        ratio = problem.error(problem.step(compute, narrow))
    return StorageSearch(alone, narrow, ratio)
