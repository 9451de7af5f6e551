"""The price of warm starting on one step: error against the exact reference after 1, 2, 4, 8 iterations, cold and
warm, and the kernel cycles of each (``models/cycle_model.py``).

A warm start needs the previous step's impulses, so the step is captured through the closed loop
(``models.closed_loop``, warm remedy): pybullet's own solver settles the scene for ``--settle`` steps, then our loop
runs ``--steps`` steps warm-started in float64, and its last step is solved again in the format from the same bodies
and constraints (rounded once) cold (zeros) and warm (the carried impulses rounded and applied on the host), each
against ``models.exact_reference`` of that step (float64 inputs, as the exact reference requires: a rounded normal is
not an eigenvector of a rounded isotropic inertia and its spin-damping rows would be refused).

    python -m sim.remedy_price --scene pile --settle 39 --steps 2 --format fp32 --iters 1,2,4,8 --schedule hazard
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Sequence

from models.closed_loop import Remedy, StepInput, run_closed_loop
from models.contact_solver import Impulses, SolverParams, solve
from models.cycle_model import predict_job
from models.dma_model import get_preset
from models.exact_reference import exact_reference
from models.integrator import IntegrationParams
from models.kernel_job import KernelJob
from models.number_format import FLOAT64, NumberFormat, parse_format
from models.solution_error import solution_error
from models.warm_start import WARMSTART_FACTOR, apply_impulses


def capture(scene: str, settle: int, steps: int, iterations: int, factor: float, schedule: str = "hazard",
            **params: object) -> tuple[StepInput, dict[str, int]]:
    """The last of ``steps`` warm-started float64 closed-loop steps after ``settle`` pybullet steps, and the
    warm-start report of the run."""
    r = run_closed_loop(scene, steps, FLOAT64, iterations, schedule=schedule, settle_steps=settle,
                        remedy=Remedy("warm", factor), **params)
    return r.extra["last step"], r.extra["warm start"]


def price(last: StepInput, fmt: NumberFormat, iters: Sequence[int], preset: str = "zcu102") -> list[dict[str, float]]:
    """Per iteration count: max and median |dv| (m/s) and max |dw| (rad/s) against the exact reference, cold and
    warm, and the kernel cycles of the step (the cycle model; the same schedule and passes either way)."""
    if last.initial is None:
        raise ValueError("the captured step carries no warm-start impulses (the loop ran cold)")
    ref = exact_reference(last.bodies, last.cons, SolverParams())
    dyn = last.bodies.dynamic
    bodies, cons = last.bodies.rounded(fmt), last.cons.rounded(fmt)
    initial = Impulses(fmt.round(last.initial.normal), fmt.round(last.initial.friction))
    warm_bodies = apply_impulses(bodies, cons, initial, fmt)
    rows = []
    for it in iters:
        params = SolverParams(iterations=it)
        cold = solve(bodies, cons, last.order, fmt, params).bodies
        warm = solve(warm_bodies, cons, last.order, fmt, params, initial=initial).bodies
        ec, ew = solution_error(cold, ref.bodies, dyn), solution_error(warm, ref.bodies, dyn)
        job = KernelJob(fmt, bodies, cons, last.order, params, IntegrationParams())
        rows.append({"iterations": it, "cold max |dv|": ec.max_dv, "cold median |dv|": ec.median_dv,
                     "cold max |dw|": ec.max_dw, "warm max |dv|": ew.max_dv, "warm median |dv|": ew.median_dv,
                     "warm max |dw|": ew.max_dw, "cycles": predict_job(job, get_preset(preset)).cycles})
    return rows


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m sim.remedy_price", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="pile")
    ap.add_argument("--settle", type=int, default=39, help="pybullet steps first (the pile's capture step is 40)")
    ap.add_argument("--steps", type=int, default=2, help="warm-started closed-loop steps; the last one is priced")
    ap.add_argument("--format", default="fp32")
    ap.add_argument("--loop-iters", type=int, default=4, help="iterations of the loop's steps before the priced one")
    ap.add_argument("--iters", default="1,2,4,8")
    ap.add_argument("--factor", type=float, default=WARMSTART_FACTOR)
    ap.add_argument("--schedule", default="hazard", help="manifold order (models/schedule.py; make sim's default)")
    args = ap.parse_args(argv)
    try:
        iters = [int(x) for x in args.iters.split(",") if x.strip()]
        fmt = parse_format(args.format)
        if args.steps < 2 or not iters or min(iters) < 1:
            raise ValueError("--steps must be >= 2 (a warm start needs a previous step), iterations >= 1")
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    t0 = time.perf_counter()
    last, report = capture(args.scene, args.settle, args.steps, args.loop_iters, args.factor, args.schedule)
    rows = price(last, fmt, iters)
    print(f"{args.scene}: {last.bodies.num_bodies} bodies, {last.cons.num_manifolds} manifolds, {fmt.name}, "
          f"{args.schedule} schedule, warm start factor {args.factor}; the loop's warm starts: {report}")
    keys = list(rows[0])
    print("| " + " | ".join(keys) + " |\n" + "|---" * len(keys) + "|")
    for r in rows:
        print("| " + " | ".join(f"{r[k]:.4g}" if isinstance(r[k], float) else f"{r[k]:,}" for k in keys) + " |")
    print(f"({time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
