"""The step's errors against the exact reference, typed for ``make sim`` and ``make sweep``.

The exact limit of the scheme (``models/exact_reference.py``) is computed once per frame and cached beside it
(``models/exact_reference_cache.py``), integrated like every solve, and compared with each solved step by
``models.solution_error.solution_error``: per-body |dv| (m/s) and |dw| (rad/s), their maximum, median and 99th
percentile over the dynamic bodies, and the maxima relative to the reference's largest speeds. When there is no
exact reference (solver failure, infeasible or degenerate problem, time or memory budget), the step's errors are
``sim.run_result.NoExactReference`` with the reason, rendered ``no exact reference (reason)`` instead of numbers.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Union

import numpy as np

from models.constraints import BodyTable, ConstraintSet
from models.contact_solver import SolverParams
from models.exact_bound import contact_phase_bound
from models.exact_reference import Budget, ExactReferenceError
from models.exact_reference_cache import cached_exact_reference
from models.integrator import IntegrationParams, integrate
from models.number_format import FLOAT64
from models.scenes.frame_cache import FRAME_CACHE_DIR
from models.solution_error import SolutionError, solution_error
from sim.run_result import ExactErrors, ExactReferenceFacts, NoExactReference


@dataclass(frozen=True)
class ExactStep:
    """The exact reference of one step, integrated (``final``), and what the report says of it."""

    final: BodyTable
    facts: ExactReferenceFacts


AnyExactStep = Union[ExactStep, NoExactReference]


def add_exact_args(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--exact-budget", type=float, default=600.0,
                    help="seconds allowed for the exact reference (models/exact_reference.py; cached beside the frame)")


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
    bound: dict[str, Any]
    try:
        bound = contact_phase_bound(bodies, cons, ref.impulses.normal)
    except ExactReferenceError as exc:
        bound = {"certified bound": str(exc)}
    facts = ExactReferenceFacts(ref.solver, ref.islands, dict(ref.seconds), dict(ref.details), dict(ref.residuals),
                                bound, str(path), hit)
    return ExactStep(integrate(ref.bodies, FLOAT64, ip), facts)


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
