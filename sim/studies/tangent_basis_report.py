"""The streaming kernel with the impulses in the records, with and without the tangent basis derived on chip: what
the record layout, the cycle model, the resource model and the golden model say (``python -m
sim.studies.tangent_basis_report``; the RTL run of the derived layout: ``make sim IMPULSE_STORE=records TANGENTS=chip``).

For each layout: the friction record's bits and beats, the kernel cycles and cycles per manifold-pass on the
preset, the fit verdict with Yosys's and the published vendor operator figures, and the golden model's error
against the float64 solve of the same iterations (max |dv|, |dw| over the dynamic bodies after integration), plus
how far the two golden results lie apart. Each layout runs the hazard schedule of its own window (its pipes'
latencies over its records' beats), so the float64 reference is the solve of the streamed layout's schedule.

    python -m sim.studies.tangent_basis_report [--scene thesis --format fp32 --dma zcu102 --iters 4 --seed 1]
"""

from __future__ import annotations

import argparse
import math
import dataclasses
import sys
import time
from collections.abc import Sequence

import numpy as np

from models.setup.constraints import BodyTable, ConstraintSet, body_table, setup_constraints
from models.golden.contact_solver import SolverParams, solve
from models.timing.cycle_model import predict_job
from models.timing.platforms import get_preset
from models.golden.integrator import IntegrationParams, integrate
from models.kernel.kernel_job import KernelJob
from models.timing.kernel_shape import KernelShape
from models.formats.number_format import FLOAT64, KERNEL_FORMATS
from models.scenes.frame_cache import load_scene
from models.order.manifold_schedule import make_schedule
from sim.fit import resource_model as rm
from sim.compile.kernel_build import default_window
from sim.drive.kernel_step import golden_step
from models.timing import platforms


def max_velocity_error(ours: BodyTable, ref: BodyTable, dyn: np.ndarray) -> tuple[float, float]:
    dv = np.abs(ours.linear_velocity[dyn] - ref.linear_velocity[dyn])
    dw = np.abs(ours.angular_velocity[dyn] - ref.angular_velocity[dyn])
    return float(dv.max(initial=0.0)), float(dw.max(initial=0.0))


def issue_window(job: KernelJob, cons_bits: int) -> int:
    """The hazard schedule's window for the job's pipes and record beats (``sim.compile.kernel_build.default_window``'s
    rule on the job's layout: with two pipes per lane the friction pipe that derives the tangents is deeper, its record
    one beat; the shared datapath binds it within the contact latency)."""
    shape = KernelShape.of(job.fmt, cons_bits, impulses_in_records=job.impulses_in_records,
                           tangents_on_chip=job.tangents_on_chip, shared_datapath=job.shared_datapath)
    return max(math.ceil(shape.contact_latency / shape.contact_beats),
               math.ceil(shape.friction_latency / shape.friction_beats)) + 2


def rows(job: KernelJob, bodies: BodyTable, cons: ConstraintSet, dma: str) -> list[list[str]]:
    """The table rows: the tangents streamed; derived on chip on the same schedule (the tangents' rounding alone:
    the last row, how far its golden result lies from the first); derived on chip on the hazard schedule of its own
    window. Errors against the float64 solve (``bodies``, ``cons`` unrounded) of the row's schedule."""
    preset, platform = get_preset(dma), platforms.get_platform(dma)
    dyn = job.bodies.dynamic
    derived = job.tangents_derived()
    own = issue_window(derived, preset.stream_bits)
    base = default_window(job.fmt, preset.stream_bits, job.shared_datapath)  # make sim's window
    variants = [("in the record", job, base), ("derived on chip, the same schedule", derived, base),
                ("derived on chip, its own schedule window", derived, own)]
    out, finals = [], []
    for label, j, window in variants:
        j = dataclasses.replace(j, schedule=make_schedule("hazard", j.cons, j.bodies.dynamic, window))
        lay = j.stream_layout(preset.stream_bits)
        pred = predict_job(j, preset)
        cfg = rm.config_for_job(j)
        fits = [rm.short_verdict(rm.fit(dataclasses.replace(cfg, operator_source=s), platform))
                for s in ("yosys", "vendor")]
        final = golden_step(j).final
        finals.append(final)
        ref = integrate(solve(bodies, cons, j.schedule, FLOAT64, j.params).bodies, FLOAT64, j.iparams)
        dv, dw = max_velocity_error(final, ref, dyn)
        out.append([label, str(window), f"{lay.friction_bits} ({lay.friction_beats})", f"{pred.cycles:,}",
                    f"{pred.cycles / max(pred.manifold_passes, 1):.4f}", f"{fits[0]}; vendor operators: {fits[1]}",
                    f"{dv:.3g} / {dw:.3g}"])
    dv, dw = max_velocity_error(finals[1], finals[0], dyn)
    out.append(["the tangents' rounding alone (row 2 against row 1)", "", "", "", "", "", f"{dv:.3g} / {dw:.3g}"])
    return out


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m sim.studies.tangent_basis_report", description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="thesis")
    ap.add_argument("--format", default="fp32", choices=list(KERNEL_FORMATS))
    ap.add_argument("--dma", default="zcu102", choices=list(platforms.PLATFORMS))
    ap.add_argument("--iters", type=int, default=4)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--shared-datapath", type=int, default=1, choices=(0, 1),
                    help="1: one datapath per lane (the builds' default); 0: a contact and a friction pipe per lane")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    fmt = KERNEL_FORMATS[args.format]
    try:
        frame, label = load_scene(args.scene, "", args.seed)
    except (KeyError, ValueError, FileNotFoundError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    bodies = body_table(frame)
    cons = setup_constraints(frame, bodies)
    schedule = np.arange(cons.num_manifolds)  # each row makes its own hazard schedule
    params = SolverParams(iterations=args.iters)
    ip = IntegrationParams(dt=frame.dt, gravity=tuple(frame.gravity))
    job = KernelJob(fmt, bodies.rounded(fmt), cons.rounded(fmt), schedule, params, ip,
                    shared_datapath=bool(args.shared_datapath)).impulses_travelling()
    table = rows(job, bodies, cons, args.dma)
    print(f"{label}: {frame.num_bodies:,} bodies, {frame.num_manifolds:,} manifolds, {fmt.name}, {args.iters} "
          f"iterations, {args.dma}, impulses in the records, {job.body_banks} body banks, "
          + ("one datapath per lane" if job.shared_datapath else "a contact and a friction pipe per lane") + "\n")
    head = ["tangent basis", "schedule window", "friction record bits (beats)", "cycles", "cycles per manifold-pass", "fit",
            f"max |dv| / |dw| vs float64 ({args.iters} iterations)"]
    print("| " + " | ".join(head) + " |\n|" + "---|" * len(head))
    for r in table:
        print("| " + " | ".join(r) + " |")
    print(f"\n{time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
