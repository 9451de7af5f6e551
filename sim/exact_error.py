"""Error lines against the exact reference, for ``make sim`` and ``make sweep``.

The exact limit of the scheme (``models/exact_reference.py``) is computed once per frame and cached beside it
(``models/exact_reference_cache.py``), integrated like every solve, and compared with each solved step by
``models.solution_error.solution_error``: per-body |dv| (m/s) and |dw| (rad/s), their maximum, median and 99th
percentile over the dynamic bodies, and the maxima relative to the reference's largest speeds. When there is no
exact reference (solver failure, infeasible or degenerate problem, time or memory budget), every line says
``no exact reference`` and why instead of a number.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from models.constraints import BodyTable, ConstraintSet
from models.contact_solver import SolverParams
from models.exact_bound import contact_phase_bound
from models.exact_reference import Budget, ExactReference, ExactReferenceError
from models.exact_reference_cache import cached_exact_reference
from models.integrator import IntegrationParams, integrate
from models.number_format import FLOAT64
from models.solution_error import solution_error

NO_REFERENCE = "no exact reference"
FRAME_CACHE_DIR = Path("build/frames")  # models.scenes.load_or_capture's default


@dataclass
class ExactStep:
    """The exact reference of one step, integrated (``final``), or why there is none (``reason``)."""

    ref: ExactReference | None
    final: BodyTable | None
    reason: str
    cache_file: str
    from_cache: bool
    bound: dict[str, Any] = field(default_factory=dict)  # models/exact_bound.py on the contact phase


def add_exact_args(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--exact-budget", type=float, default=600.0,
                    help="seconds allowed for the exact reference (models/exact_reference.py; cached beside the frame)")


def reference_dir(args: argparse.Namespace) -> Path:
    """Where the frame lies, so the reference is cached beside it."""
    return Path(args.frame).parent if getattr(args, "frame", "") else FRAME_CACHE_DIR


def exact_step(bodies: BodyTable, cons: ConstraintSet, ip: IntegrationParams, cache_dir: Path,
               budget_s: float, params: SolverParams = SolverParams()) -> ExactStep:
    try:
        ref, path, hit = cached_exact_reference(bodies, cons, cache_dir, params, Budget(time_s=budget_s))
    except ExactReferenceError as exc:
        print(f"{NO_REFERENCE}: {exc}", flush=True)
        return ExactStep(None, None, str(exc), "", False)
    try:
        bound = contact_phase_bound(bodies, cons, ref.impulses.normal)
    except ExactReferenceError as exc:
        bound = {"certified bound": str(exc)}
    return ExactStep(ref, integrate(ref.bodies, FLOAT64, ip), "", str(path), hit, bound)


def error_rows(label: str, ours: BodyTable, exact: ExactStep, dynamic: np.ndarray) -> dict[str, Any]:
    """``label: <metric>`` rows against the exact reference, or one ``no exact reference`` row."""
    if exact.final is None:
        return {f"{label}": f"{NO_REFERENCE} ({exact.reason})"}
    return {f"{label}: {k}": v for k, v in solution_error(ours, exact.final, dynamic).items()}


def reference_rows(exact: ExactStep) -> dict[str, Any]:
    """The reference's own figures: solver, islands, solve times, natural residuals, cache file."""
    if exact.ref is None:
        return {"exact reference": f"{NO_REFERENCE} ({exact.reason})"}
    ref = exact.ref
    rows: dict[str, Any] = {"exact reference: solver": ref.solver, "exact reference: islands": ref.islands}
    rows.update({f"exact reference: {k} solve time (s)": v for k, v in ref.seconds.items()})
    rows.update({f"exact reference: {k}": v for k, v in ref.details.items()})
    rows.update({f"exact reference residual, {k}": v for k, v in ref.residuals.items()})
    rows.update({f"exact reference, contact phase, {k}": v for k, v in exact.bound.items()})
    rows["exact reference: cache file"] = exact.cache_file + (" (read from the cache)" if exact.from_cache else "")
    return rows
