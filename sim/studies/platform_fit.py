"""Which built kernel configurations fit a platform, and how fast the cycle model says they are, on one scene.

For every format, the streaming kernel with the impulses on chip and with them in the records (``make sim
IMPULSE_STORE=``) in the hazard order, and the window kernel with a ring of ``--ring`` records, 1, 2 or 4 lanes
(``RECORD_WINDOW= LANES=``), also with the impulses in the records, in the sweep order (its band
width sets the ring's trailing passes): the cycle model's cycles of the ``--iters``-iteration step at the DMA preset
(``models/timing/cycle_model.py``, the window kernel's ``models/timing/window_cycle_model.py``), and the resource
model's shares of the preset's platform with the verdict (``sim/fit/resource_model.py``, the configuration as built: the
figures ``make sim`` prints). No golden model runs: seconds per configuration.

    python -m sim.studies.platform_fit --scene thesis --dma u280 [--formats fp32,fp16,bf16 --iters 4 --ring 16384]
"""

from __future__ import annotations

import argparse
import sys
from typing import Iterator, Sequence

from models.timing import cycle_model
from models.setup.constraints import body_table, setup_constraints
from models.golden.integrator import IntegrationParams
from models.golden.contact_solver import SolverParams
from models.timing.platforms import get_preset
from models.kernel.kernel_job import KernelJob
from models.order.manifold_schedule import make_schedule
from sim.compile.kernel_build import default_window
from sim.fit.resource_model import KEYS, FitVerdict, kernel_fit
from sim.drive.run_options import hardware_format, load_frame

LANES = (1, 2, 4)


def configurations(base: KernelJob, swept: KernelJob, ring: int) -> Iterator[tuple[str, KernelJob]]:
    """The built designs of ``base``'s step: the two streaming ones, then on ``swept`` (the same step in the sweep
    order; ``ring`` > 0) the window kernel's lane counts and its one-lane design with the impulses in the
    records."""
    yield "streaming, impulses on chip", base
    yield "streaming, impulses in the records", base.impulses_travelling()
    if ring:
        for lanes in LANES:
            yield f"window {ring:,} x{lanes}", swept.windowed(ring, lanes=lanes)
        for lanes in LANES:
            yield f"window {ring:,} x{lanes}, impulses in the records", swept.impulses_travelling().windowed(
                ring, lanes=lanes)


def table(args: argparse.Namespace) -> list[str]:
    """The markdown table's lines."""
    preset = get_preset(args.dma)
    frame, label = load_frame(args)
    bodies = body_table(frame)
    cons = setup_constraints(frame, bodies)
    ip = IntegrationParams(dt=frame.dt, gravity=tuple(frame.gravity))
    lines = [f"{label}, {args.dma}, {args.iters} iterations ({frame.num_bodies:,} bodies, {frame.num_manifolds:,} "
             f"manifolds), {args.body_bits}-bit body streams", "",
             "| design | cycles | cycles per manifold-pass | " + " | ".join(KEYS) + " | verdict |",
             "|---|---|---|" + "---|" * len(KEYS) + "---|"]
    for name in (f.strip() for f in args.formats.split(",") if f.strip()):
        fmt = hardware_format(name)
        w = default_window(fmt, preset.stream_bits)
        base, swept = (KernelJob(fmt, bodies.rounded(fmt), cons.rounded(fmt),
                                 make_schedule(kind, cons, bodies.dynamic, w), SolverParams(args.iters), ip)
                       for kind in ("hazard", "sweep"))
        for design, job in configurations(base, swept, args.ring):
            v = kernel_fit(job, args.dma, args.body_bits)
            cycles = cycle_model.predict_job(job, preset, body_bits=args.body_bits).cycles
            speed = f"{cycles:,} | {cycles / job.manifold_passes:.3f}"
            if isinstance(v, FitVerdict):
                shares = " | ".join(f"{100 * v.shares[k]:.1f}%" for k in KEYS)
                verdict = v.headline()
            else:
                shares, verdict = " | ".join("-" for _ in KEYS), f"no estimate ({v.reason})"
            lines.append(f"| {fmt.name} {design} | {speed} | {shares} | {verdict} |")
            print(lines[-1], flush=True)
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m sim.studies.platform_fit", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="thesis")
    ap.add_argument("--scene-args", default="")
    ap.add_argument("--frame", default="")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--dma", default="u280")
    ap.add_argument("--formats", default="fp32,fp16,bf16")
    ap.add_argument("--iters", type=int, default=4)
    ap.add_argument("--ring", type=int, default=16384, help="the window kernel's ring (0: no window kernel rows)")
    ap.add_argument("--body-bits", type=int, default=128, help="the body streams' beat (make sim BODY_BITS)")
    args = ap.parse_args(argv)
    try:
        if args.iters < 1:
            raise ValueError(f"--iters must be >= 1, got {args.iters}")
        if args.ring and (args.ring < 2 or args.ring & (args.ring - 1)):
            raise ValueError(f"--ring must be 0 or a power of two >= 2, got {args.ring}")
        print("\n".join(table(args)))
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
