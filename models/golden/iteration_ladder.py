"""Every iteration count of a sweep from one solve: the golden model's steps after 1, 2, 4, ... N iterations.

With the contact phase first (``SolverParams(interleaved=False)``, Bullet's GPU order), the N-iteration step is N
contact passes from zero impulses, then N friction passes, then the integration. Its contact phase is the first N
contact passes of any longer run over the same schedule (a pass reads only the velocities and impulses the passes
before it left; the iteration number is a trace label, no input), so one contact run with a snapshot after each
asked count, and a friction phase and an integration from each snapshot, give every count's step bit for bit as
its own solve does: ``max(N)`` contact passes and ``sum(N)`` friction passes instead of ``2 sum(N)`` passes.
With the interleaved order the N-iteration run is the first N (contact, friction) pairs of the longer one: one run
with a snapshot after each asked count.

    finals = solve_ladder(job.bodies, job.cons, job.schedule, job.fmt, (1, 2, 4, 8), job.iparams)
    finals[4]  # == golden_step(job with SolverParams(iterations=4)).final, bit for bit
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from models.setup.constraints import BodyTable, ConstraintSet
from models.golden.contact_solver import CONTACT_PASS, FRICTION_PASS, Impulses, SolverParams, run_pass, schedule_levels
from models.golden.integrator import IntegrationParams, integrate
from models.formats.number_format import Arithmetic


def solve_ladder(bodies: BodyTable, cons: ConstraintSet, schedule: np.ndarray, ar: Arithmetic,
                 counts: Sequence[int], iparams: IntegrationParams,
                 params: SolverParams = SolverParams()) -> dict[int, BodyTable]:
    """The integrated step after each iteration count of ``counts`` (``params.iterations`` is ignored), from zero
    impulses; ``bodies`` and ``cons`` already hold values of the arithmetic's format, as for ``solve``."""
    wanted = sorted(set(int(n) for n in counts))
    if not wanted or wanted[0] < 1:
        raise ValueError(f"iteration counts must be positive integers, got {list(counts)!r}")
    levels = schedule_levels(schedule, cons, bodies.dynamic)
    out = bodies.copy()
    imp = Impulses.zeros(cons.num_manifolds)
    snapshots: dict[int, tuple[BodyTable, Impulses]] = {}
    for it in range(wanted[-1]):
        run_pass(out, imp, cons, levels, ar, CONTACT_PASS, it, params, schedule)
        if params.interleaved:
            run_pass(out, imp, cons, levels, ar, FRICTION_PASS, it, params, schedule)
        if it + 1 in wanted:
            snapshots[it + 1] = (out.copy(), imp.copy())
    finals: dict[int, BodyTable] = {}
    for n, (state, impulses) in snapshots.items():
        if not params.interleaved:
            for it in range(n):
                run_pass(state, impulses, cons, levels, ar, FRICTION_PASS, it, params, schedule)
        finals[n] = integrate(state, ar, iparams)
    return finals
