"""``make sim``: a scene in, the PGS step solved, figures out.

Until the RTL kernel is wired in, the run solves the frame with the reference model: float64 and the
bit-accurate golden model of the chosen number format, with the chosen schedule, and reports the scene,
the schedule, the solve times and the error of the format against float64 and of our GPU-style step
against pybullet's own step.

    python -m sim.run --scene pile --iters 4 --format fp32 --seed 1
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from models import scenes
from models.constraints import BodyTable, body_table, setup_constraints
from models.contact_solver import SolverParams, solve
from models.dma_model import PRESETS, get_preset
from models.frame import FrameError
from models.integrator import IntegrationParams, integrate
from models.number_format import FLOAT64, parse_format
from models.schedule import make_schedule, stats
from sim.report import print_summary, write_report

def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(prog="python -m sim.run", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="pile", help=f"scene name ({', '.join(sorted(scenes.SCENES))})")
    ap.add_argument("--iters", type=int, default=4, help="PGS iterations per pass type (Bullet GPU: 4)")
    ap.add_argument("--format", default="fp32", help="number format: fp32, fp16, bf16 or eXmY")
    ap.add_argument("--dma", default="zcu102", help=f"DMA preset ({', '.join(PRESETS)})")
    ap.add_argument("--seed", type=int, default=1, help="scene seed (jitter)")
    ap.add_argument("--schedule", default="hazard", help="manifold order: hazard or pybullet")
    ap.add_argument("--window", type=int, default=64, help="hazard window W in issue slots")
    ap.add_argument("--out", default="build/sim", help="parent directory of the run directory")
    return ap.parse_args(argv)


def velocity_error(ours: BodyTable, ref_lin: np.ndarray, ref_ang: np.ndarray, dynamic: np.ndarray) -> dict[str, float]:
    dv = np.abs(ours.linear_velocity[dynamic] - ref_lin[dynamic])
    dw = np.abs(ours.angular_velocity[dynamic] - ref_ang[dynamic])
    scale = max(float(np.max(np.abs(ref_lin[dynamic]), initial=0.0)), 1e-12)
    return {"max |dv| (m/s)": float(dv.max(initial=0.0)), "max |dw| (rad/s)": float(dw.max(initial=0.0)),
            "max |dv| / max |v|": float(dv.max(initial=0.0)) / scale}


def run(args: argparse.Namespace) -> dict[str, dict[str, Any]]:
    get_preset(args.dma)
    if args.iters < 1:
        raise ValueError(f"ITERS must be >= 1, got {args.iters}")
    fmt = parse_format(args.format)
    t0 = time.perf_counter()
    frame = scenes.load_or_capture(args.scene, seed=args.seed)
    t_frame = time.perf_counter() - t0
    print(frame.summary(), f"(frame ready in {t_frame:.1f} s)", flush=True)

    bodies = body_table(frame)
    cons = setup_constraints(frame, bodies)
    schedule = make_schedule(args.schedule, cons, bodies.dynamic, args.window)
    sched_stats = stats(args.schedule, schedule, cons, bodies.dynamic, args.window)
    print(sched_stats.describe(), flush=True)
    params = SolverParams(iterations=args.iters)
    ip = IntegrationParams(dt=frame.dt, gravity=tuple(frame.gravity))

    t = time.perf_counter()
    ref = solve(bodies, cons, schedule, FLOAT64, params)
    ref_bodies = integrate(ref.bodies, FLOAT64, ip)
    t_ref = time.perf_counter() - t
    print(f"float64 reference: {t_ref:.2f} s ({ref.levels} levels per pass)", flush=True)

    t = time.perf_counter()
    gold = solve(bodies.rounded(fmt), cons.rounded(fmt), schedule, fmt, params)
    gold_bodies = integrate(gold.bodies, fmt, ip)
    t_gold = time.perf_counter() - t
    print(f"{fmt.name} golden model: {t_gold:.2f} s", flush=True)

    dyn = bodies.dynamic
    passes = 2 * args.iters
    return {
        "scene": {"scene": args.scene, "bodies": frame.num_bodies, "dynamic bodies": int(dyn.sum()),
                  "manifolds": frame.num_manifolds, "contact points": frame.num_points_total,
                  "step": frame.meta.get("step", "?"), "seed": args.seed},
        "schedule": {"kind": args.schedule, "window W": args.window, "slots per pass": sched_stats.slots,
                     "bubbles per pass": sched_stats.bubbles, "wrap hazards": sched_stats.wrap_conflicts,
                     "levels per pass": ref.levels, "manifold-passes": frame.num_manifolds * passes},
        "solve time (this machine)": {"frame load/capture (s)": t_frame, "float64 reference (s)": t_ref,
                                      f"{fmt.name} golden model (s)": t_gold},
        f"error of {fmt.name} against float64 (same schedule and iterations, post-solve velocities)":
            velocity_error(gold.bodies, ref.bodies.linear_velocity, ref.bodies.angular_velocity, dyn),
        "difference of our float64 GPU-style step from pybullet's own step (different solver)":
            velocity_error(ref_bodies, frame.post_linear_velocity, frame.post_angular_velocity, dyn),
    }


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        sections = run(args)
    except (ValueError, FrameError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    run_dir = Path(args.out) / f"{args.scene}-{args.format}-it{args.iters}-s{args.seed}"
    print_summary(f"pgs-cosim: {args.scene}, {args.format}, {args.iters} iterations (reference model)", sections)
    json_path, md_path = write_report(run_dir, f"pgs-cosim run: {args.scene}", sections)
    print(f"\nreport: {md_path} and {json_path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
