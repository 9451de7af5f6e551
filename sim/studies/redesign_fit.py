"""What the resource model says of the redesign levers on a scene's sizes: which kernels fit a platform, at what
estimated cost (``python -m sim.studies.redesign_fit``; the table of docs/resources.md).

For every format, kernel (the streaming kernel; the window kernel with 1, 2 or 4 lanes) and lever setting
(impulses resident or travelling with the records; the whole body record or only velocities and mass properties
on chip; body ports as a live-value table or banks: for the streaming kernel the built ``BODY_BANKS`` memory of
``models.kernel.body_banks`` (2 true dual-port banks, a busy bank stalls the issue: measured by the cycle model, not in
the floor), for the window kernel 8 banks (``models.kernel.body_banks.WINDOW_BANKS``, any lanes, a record's reads kept
within their ports by the lane plan); operator figures from Yosys or, where
published, from Vitis HLS; the pipes' delay lines from 65 deep in LUT RAM or in block RAM,
``models.kernel.delay_lines``) it prints the estimated LUT, FF, DSP, BRAM36 and URAM as shares of the platform, the
verdict, and the DDR / compute floor in cycles per manifold-pass of the kernel's fetch schedule
(``models.sizing.onchip_budget.floors``: the streaming kernel reads every record every pass, the window kernel once per
step, as the README's window runs with FETCH_PASSES=0 do). Body words and ports change the resources, not the floor
(busy banks may cost issue slots the floor does not count). Sizes default to the thesis frame (38,881 bodies, 147,485
manifolds) and the README's ring of 16,384 records.

    python -m sim.studies.redesign_fit --platform zcu102 [--bodies 38881 --manifolds 147485 --ring 16384 --iters 4
                               --fetch-every 0]
"""

from __future__ import annotations

import argparse
import itertools
import sys
from dataclasses import dataclass
from typing import Any, Sequence

from models.sizing import onchip_budget as ob
from models.kernel.body_banks import RECORDS_BANKS, WINDOW_BANKS
from models.kernel.delay_lines import BLOCK_MIN_DEPTH
from models.formats.number_format import FP16, FP32, NumberFormat
from models.scenes.specs import THESIS_FRAME_BODIES as THESIS_BODIES
from models.scenes.specs import THESIS_FRAME_MANIFOLDS as THESIS_MANIFOLDS
from models.timing import platforms
from sim.fit import resource_model as rm

README_RING = 16_384


@dataclass(frozen=True)
class Row:
    config: rm.KernelConfig
    verdict: rm.FitVerdict
    floor: ob.Floors


def rows(platform: platforms.Platform, formats: Sequence[NumberFormat], bodies: int, manifolds: int, ring: int,
         iters: int, fetch_every: int = 0, data: dict[str, Any] | None = None) -> list[Row]:
    """Every lever setting; the window kernel fetches its records once per ``fetch_every`` iterations (0: once per
    step)."""
    data = data or rm.figures()
    out = []
    kernels = [(0, 1)] + [(ring, lanes) for lanes in (1, 2, 4)]
    levers = itertools.product((True, False), ("full", "solve"), ("lvt", "banked"), ("yosys", "vendor"),
                               (0, BLOCK_MIN_DEPTH))
    for fmt, (window, lanes), (resident, body, ports, source, delay) in itertools.product(formats, kernels,
                                                                                          list(levers)):
        if source == "vendor" and not any(f == fmt.name for _, f in rm.VENDOR_OPERATORS):
            continue  # no published figure in this format: the same as Yosys's
        cfg = rm.KernelConfig(fmt, bodies, manifolds, lanes=lanes, window=window, impulses_resident=resident,
                              body_words=body, body_ports=ports, operator_source=source, delay_block_min_depth=delay,
                              body_banks=WINDOW_BANKS if window else RECORDS_BANKS)
        fl = ob.floors(platform, fmt, bodies, manifolds, iters, (fetch_every or iters) if window else 0, lanes,
                       resident)
        out.append(Row(cfg, rm.verdict(rm.estimate(cfg, platform, data), platform), fl))
    return out


def describe(c: rm.KernelConfig) -> str:
    kernel = "streaming" if not c.window else f"window x{c.lanes}"
    return (f"{c.fmt.name} | {kernel} | {'resident' if c.impulses_resident else 'with records'} | {c.body_words} | "
            f"{c.body_ports} | {c.operator_source} | {'block RAM' if c.delay_block_min_depth else 'LUT RAM'}")


def table(found: Sequence[Row], only_fitting: bool) -> list[str]:
    head = ("| format | kernel | impulses | body words | body ports | operator figures | long delay lines | LUT | FF | "
            "DSP | BRAM36 | URAM | verdict | floor c/mp (bound) |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for r in sorted(found, key=lambda r: r.floor.cycles_per_manifold_pass):
        if r.verdict.fits != only_fitting:
            continue
        sh = r.verdict.shares
        lines.append(f"| {describe(r.config)} | " + " | ".join(f"{100 * sh[k]:.0f}%" if sh[k] != float("inf")
                                                              else "none on device" for k in rm.KEYS)
                     + f" | {rm.short_verdict(r.verdict)} | {r.floor.cycles_per_manifold_pass:.3f} ({r.floor.bound}) |")
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m sim.studies.redesign_fit", description=__doc__.splitlines()[0])
    ap.add_argument("--platform", default="zcu102", choices=list(platforms.PLATFORMS))
    ap.add_argument("--formats", default="fp32,fp16")
    ap.add_argument("--bodies", type=int, default=THESIS_BODIES)
    ap.add_argument("--manifolds", type=int, default=THESIS_MANIFOLDS)
    ap.add_argument("--ring", type=int, default=README_RING, help="records in the window kernel's ring")
    ap.add_argument("--iters", type=int, default=4)
    ap.add_argument("--fetch-every", type=int, default=0,
                    help="the window kernel fetches once per this many iterations (0: once per step); its ring must "
                         "hold (passes per fetch - 1) x lag + 2 records")
    args = ap.parse_args(argv)
    by_name = {f.name: f for f in (FP32, FP16)}
    try:
        fmts = [by_name[f] for f in args.formats.split(",")]
        platform = platforms.get_platform(args.platform)
        if args.fetch_every < 0 or args.iters < 1:
            raise ValueError("--fetch-every must be >= 0 and --iters >= 1")
        found = rows(platform, fmts, args.bodies, args.manifolds, args.ring, args.iters, args.fetch_every)
    except (KeyError, ValueError, FileNotFoundError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"{platform.name} ({platform.describe()}); {args.bodies:,} bodies, {args.manifolds:,} manifolds, ring "
          f"{args.ring:,} records fetched once per {args.fetch_every or args.iters} iteration(s), {args.iters} "
          f"iterations; usable: {platforms.describe_usable()}\n")
    print("fitting designs, fastest floor first:\n")
    print("\n".join(table(found, True)))
    print("\ndesigns that do not fit:\n")
    print("\n".join(table(found, False)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
