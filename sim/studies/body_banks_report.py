"""Kernel cycles of a scene's step for each count of body-velocity banks (``BODY_BANKS``, models/kernel/body_banks.py),
with the fit verdict of each (``python -m sim.studies.body_banks_report``; cycle and resource models, no RTL).

    python -m sim.studies.body_banks_report [--scene thesis --format fp32 --dma zcu102 --iters 4 --seed 1 --banks
    0,1,2,4,8]

The streaming kernel with the impulses in the records (the design that banks its velocities). "stall cycles on
a busy bank" are the stall cycles of the records whose last wait was a busy bank (the cycle model's cause split).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from collections.abc import Sequence

from models.golden.contact_solver import SolverParams
from models.timing.stream_cycle_model import predict
from models.timing.platforms import get_preset
from models.kernel.kernel_job import KernelJob
from models.timing.kernel_shape import DmaTiming, KernelShape, StepShape
from models.formats.number_format import KERNEL_FORMATS
from models.scenes.frame_cache import load_scene
from sim.fit import resource_model as rm
from sim.compile.kernel_build import default_window
from models.timing import platforms

BUSY = "body bank busy with a retire write"


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m sim.studies.body_banks_report", description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="thesis")
    ap.add_argument("--format", default="fp32", choices=list(KERNEL_FORMATS))
    ap.add_argument("--dma", default="zcu102", choices=list(platforms.PLATFORMS))
    ap.add_argument("--iters", type=int, default=4)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--banks", default="0,1,2,4,8")
    args = ap.parse_args(argv)
    try:
        banks = [int(b) for b in args.banks.split(",")]
        fmt, preset, platform = KERNEL_FORMATS[args.format], get_preset(args.dma), platforms.get_platform(args.dma)
        frame, label = load_scene(args.scene, "", args.seed)
        for b in banks:
            KernelShape.of(fmt, body_banks=b)  # 0 or a power of two, else a ValueError
    except (KeyError, ValueError, FileNotFoundError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    job = KernelJob.from_frame(frame, fmt, SolverParams(args.iters), "hazard",
                               default_window(fmt, preset.stream_bits)).impulses_travelling()
    step = StepShape.of_job(job)
    dma = DmaTiming.of(preset, False, job.ddr_read_share(preset.stream_bits))
    base = rm.config_for_job(job)
    print(f"{label}: {job.bodies.num_bodies:,} bodies, {job.manifolds:,} manifolds, {fmt.name}, {args.iters} "
          f"iterations, {args.dma}, impulses in the records (the build's banks: {job.body_banks})\n")
    print("| body banks | cycles | cycles per manifold-pass | stall cycles on a busy bank | fit |\n|---|---|---|---|---|")
    for b in banks:
        shape = KernelShape.of(fmt, preset.stream_bits, inertia_words=job.inertia_words, impulses_in_records=True,
                               friction_words=job.friction_words, body_banks=b)
        pred = predict(shape, dma, step)
        cfg = dataclasses.replace(base, body_ports="banked" if b else "lvt", body_banks=b or base.body_banks)
        v = rm.fit(cfg, platform)
        print(f"| {b} | {pred.cycles:,} | {pred.cycles / max(pred.manifold_passes, 1):.4f} | "
              f"{pred.stall_cycles_by_cause().get(BUSY, 0):,} | {rm.short_verdict(v)}: {v.shares_text()} |",
              flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
