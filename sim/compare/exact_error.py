"""The step's errors against the exact reference, typed for ``make sim`` and ``make sweep``.

The exact limit of the scheme (``models/exact/reference.py``) is computed once per frame and cached beside it
(``models/exact/cache.py``), integrated like every solve, and compared with each solved step by
``models.exact.solution_error.solution_error``: per-body |dv| (m/s) and |dw| (rad/s), their maximum, median and 99th
percentile over the dynamic bodies, and the maxima relative to the reference's largest speeds. When there is no
exact reference (solver failure, infeasible or degenerate problem, time or memory budget), the step's errors are
:class:`NoExactReference` with the reason, rendered ``no exact reference (reason)`` instead of numbers.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional, Union

import numpy as np

from models.setup.constraints import BodyTable, ConstraintSet
from models.golden.contact_solver import SolverParams
from models.exact.bound import contact_phase_bound, per_body_bounds
from models.exact.phases import Budget
from models.exact.assembly import ExactReferenceError
from models.exact.cache import cached_exact_reference
from models.exact.damped_friction import not_certified_unique
from models.golden.integrator import IntegrationParams, integrate
from models.formats.number_format import FLOAT64
from models.scenes.frame_cache import FRAME_CACHE_DIR
from models.exact.solution_error import SolutionError, solution_error


NO_REFERENCE = "no exact reference"


@dataclass(frozen=True)
class NoExactReference:
    """The exact reference could not be computed (solver failure, infeasible or degenerate problem, time or memory
    budget): every error against it is this, with the reason."""

    reason: str

    def __str__(self) -> str:
        return f"{NO_REFERENCE} ({self.reason})"


@dataclass(frozen=True)
class ExactReferenceFacts:
    """The exact reference's own figures (``models/exact/reference.py``) and where it is cached."""

    solver: str
    islands: int
    seconds: dict[str, float]  # solve time by phase
    details: dict[str, float]
    residuals: dict[str, float]  # its natural residuals
    contact_bound: dict[str, Any]  # the certificate the reference was accepted with, named (sim.compare.exact_error)
    cache_file: str
    from_cache: bool
    # what the error lines measure against: the exact limit, or (friction phase not certified unique) the fixed point
    # reached from the kernel's start (reference_name)
    name: str = "exact reference"


@dataclass(frozen=True)
class ExactErrors:
    """Velocities after the step against the exact limit of the scheme (``models.exact.solution_error``)."""

    reference: ExactReferenceFacts
    ours: SolutionError  # the step's source: rounding + iteration error
    iteration_only: SolutionError  # float64 with these iterations
    converged: Optional[SolutionError] = None  # float64 PGS after the converged solve's passes (not in MODE=model)


@dataclass(frozen=True)
class ExactStep:
    """The exact reference of one step, integrated (``final``), and what the report says of it."""

    final: BodyTable
    facts: ExactReferenceFacts


AnyExactStep = Union[ExactStep, NoExactReference]


def add_exact_args(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--exact-budget", type=float, default=600.0,
                    help="seconds allowed for the exact reference (models/exact/reference.py; cached beside the frame)")


def reference_dir(args: argparse.Namespace) -> Path:
    """Where the frame lies, so the reference is cached beside it."""
    return Path(args.frame).parent if getattr(args, "frame", "") else FRAME_CACHE_DIR


def exact_step(bodies: BodyTable, cons: ConstraintSet, ip: IntegrationParams, cache_dir: Path,
               budget_s: float, params: SolverParams = SolverParams()) -> AnyExactStep:
    """The step's exact reference (solved, or read from the cache beside the frame), or why there is none."""
    try:
        ref, path, hit = cached_exact_reference(bodies, cons, cache_dir, params, Budget(time_s=budget_s))
    except ExactReferenceError as exc:
        missing = NoExactReference(str(exc))
        print(missing, flush=True)
        return missing
    facts = ExactReferenceFacts(ref.solver, ref.islands, dict(ref.seconds), dict(ref.details), dict(ref.residuals),
                                contact_certificate(bodies, cons, ref.impulses.normal, ref.details), str(path), hit,
                                reference_name(ref.details))
    return ExactStep(integrate(ref.bodies, FLOAT64, ip), facts)


NOT_UNIQUE_NAME = "the fixed point reached from the kernel's start (exact reference; the limit is not certified unique)"


def reference_name(details: dict[str, float]) -> str:
    """What the error lines measure against: the exact limit, or, where the friction phase's non-symmetric problem
    holds a component whose solution is not certified unique (``models/exact/damped_friction.py``), the
    fixed point reached from the kernel's start, named so."""
    return NOT_UNIQUE_NAME if not_certified_unique(details) else "exact reference"


PRIMAL_POINT_KEY = "certified |u - u*|_M of the contact phase (sqrt(kg) m/s)"  # models/exact/large_island.py


def contact_certificate(bodies: BodyTable, cons: ConstraintSet, normal: np.ndarray,
                        details: dict[str, float]) -> dict[str, Any]:
    """The contact phase's certified distance from its exact limit, as the reference was accepted with, named.

    A large island's reference (body-space interior point) was accepted with the smaller of the primal-point bound
    (weak duality at the interior point's primal iterate) and the impulse-only bound (from u(lam) alone, which
    carries the dual residual times the stack's summed impulses: 0.088 where the primal point gives 2.3e-6 on a
    1,960-cube stack), recorded in its details; a Clarabel reference has no primal iterate, so its certificate is
    the impulse-only bound (``models/exact/bound.py``)."""
    if any(k.startswith("interleaved:") for k in details):
        return {"certificate": "none: the interleaved order's coupled fixed point has no distance certificate (its "
                               "coupled natural residuals, above, certify a fixed point of the interleaved passes, "
                               "one of possibly several; models/exact/interleaved.py)"}
    try:
        impulse_only = contact_phase_bound(bodies, cons, normal)
    except ExactReferenceError as exc:
        impulse_only = {"certified |u - u*|_M (sqrt(kg) m/s)": float("nan"), "reason": str(exc)}
    used = details.get(PRIMAL_POINT_KEY)
    if used is None:
        if "reason" in impulse_only:
            return {"certificate": f"none ({impulse_only['reason']})"}
        return {"certificate": "impulse-only bound, from u(lam) (models.exact.bound.contact_phase_bound)",
                **{k: v for k, v in impulse_only.items() if k.startswith("certified")}}
    dv, dw = per_body_bounds(bodies, used)
    return {"certificate": "primal-point bound, at the interior point's primal iterate (the smaller of it and the "
                           "impulse-only bound; models.exact.bound._primal_gap), the one the reference was accepted "
                           "with",
            "certified |u - u*|_M (sqrt(kg) m/s)": used, "certified max |dv| (m/s)": dv,
            "certified max |dw| (rad/s)": dw,
            "impulse-only bound from u(lam), not used (sqrt(kg) m/s)":
                impulse_only["certified |u - u*|_M (sqrt(kg) m/s)"]}


def error_vs_exact(ours: BodyTable, exact: AnyExactStep, dynamic: np.ndarray) -> SolutionError | NoExactReference:
    """``ours`` against the exact reference, or why there is none."""
    if isinstance(exact, NoExactReference):
        return exact
    return solution_error(ours, exact.final, dynamic)


def exact_errors(exact: AnyExactStep, ours: BodyTable, same_iterations: BodyTable, pgs: BodyTable | None,
                 dynamic: np.ndarray) -> ExactErrors | NoExactReference:
    """The step (``ours``), float64 with the same iterations and (unless None) float64 PGS after many passes,
    each against the exact reference; or why there is none."""
    if isinstance(exact, NoExactReference):
        return exact
    return ExactErrors(exact.facts, solution_error(ours, exact.final, dynamic),
                       solution_error(same_iterations, exact.final, dynamic),
                       None if pgs is None else solution_error(pgs, exact.final, dynamic))
