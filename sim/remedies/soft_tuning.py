"""Tune Box2D's soft contact on the hard cases: a sweep of contact hertz, damping ratio and static stiffness.

Each setting runs the case closed loop (``models.closed_loop.hard_cases.HardCase.run``) under a soft remedy
(``--substeps`` n, ``--relax``: a solve and a relax call per substep; ``--warm-factor``: the warm start between steps,
by default in full as Box2D's) and prints the verdict with the judged figures, so a setting that passes can be
registered in ``models.closed_loop.hard_cases.REMEDIES``.

    python -m sim.remedies.soft_tuning --cases plank,stack20 --substeps 2 --relax --settings 30:10:2,15:10:2 --format
    float64
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Sequence

from models.closed_loop.loop import Remedy
from models.formats.number_format import parse_format
from models.golden.soft_contact import SoftContact
from models.closed_loop.hard_cases import CASES, judge


def parse_settings(text: str) -> list[SoftContact]:
    """``hertz:damping:static,...`` -> soft contact settings (a clear error on anything else)."""
    out = []
    for item in (x.strip() for x in text.split(",") if x.strip()):
        try:
            hz, zeta, static = (float(v) for v in item.split(":"))
        except ValueError:
            raise ValueError(f"setting {item!r} is not hertz:damping:static_stiffness") from None
        out.append(SoftContact(hertz=hz, damping_ratio=zeta, static_stiffness=static))
    if not out:
        raise ValueError("no setting given")
    return out


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m sim.remedies.soft_tuning", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", default="plank", help=f"comma-separated cases ({', '.join(CASES)})")
    ap.add_argument("--format", default="float64")
    ap.add_argument("--iters", type=int, default=4, help="iterations per step, shared by every kernel call")
    ap.add_argument("--substeps", type=int, default=2)
    ap.add_argument("--relax", action="store_true", help="a relax call after each substep's position update")
    ap.add_argument("--settings", default="30:10:2", help="hertz:damping_ratio:static_stiffness, comma-separated")
    ap.add_argument("--steps", type=int, default=0, help="measured steps (0: the case's own)")
    ap.add_argument("--warm-factor", type=float, default=1.0, help="warm start between steps (Box2D: 1, Bullet 2: 0.85)")
    args = ap.parse_args(argv)
    try:
        cases = [c.strip() for c in args.cases.split(",") if c.strip()]
        if not cases or any(c not in CASES for c in cases):
            raise ValueError(f"unknown case in {args.cases!r} (known: {', '.join(CASES)})")
        settings, ar = parse_settings(args.settings), parse_format(args.format)
        remedies = [Remedy(f"warm{args.warm_factor:g}+soft{s.hertz:g}z{s.damping_ratio:g}s{s.static_stiffness:g}"
                           f"+sub{args.substeps}" + ("+relax" if args.relax else ""), args.warm_factor, args.substeps,
                           relax=args.relax, soft=s)
                    for s in settings]
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    for case in cases:
        for remedy in remedies:
            t0 = time.process_time()
            result, path = CASES[case].run(ar, args.iters, args.steps or None, remedy=remedy)
            v = judge(CASES[case], result, path, args.iters)
            f = v.figures
            print(f"{case} {ar.name} {remedy.name}: {'pass' if v.passed else 'FAIL ' + '; '.join(v.failures)} | "
                  f"passes {f['passes per step']:.0f}, pen {f['max penetration (m)']:.4f} m, excursion "
                  f"{f['max excursion (m)']:.4f} m, path {f['max path length (m)']:.4f} m, speed "
                  f"{f['max speed net of g dt (m/s)']:.4f} m/s, {f['kernel cycles per step']:.0f} cycles/step "
                  f"({time.process_time() - t0:.0f} CPU s)", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
