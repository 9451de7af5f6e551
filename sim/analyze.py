"""``make analyze``: which number formats a scene needs (``models/sizing/format_analyzer.py``).

Prints the range of every field group, the narrowest single format for the kernel that keeps the step's
velocity error against float64 within the budget (what ``FORMAT=auto`` runs), and a storage format per group
with the bytes per record it would take; writes ``build/analyze/<scene>-s<seed>/analysis.json``.

    python -m sim.analyze --scene pile --budget 0.01
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any, Sequence

from models.sizing import format_analyzer as fa
from models.sizing.format_analyzer import DEFAULT_BUDGET, kernel_format, problem_of
from models import scenes
from models.formats.frame import FrameError
from models.formats.number_format import FP16, FP32
from sim.report.run_report import format_value

def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(prog="python -m sim.analyze", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="pile", help=f"scene name ({', '.join(sorted(scenes.SCENES))})")
    ap.add_argument("--scene-args", default="", help='scene parameters, e.g. "nx=20 ny=5 nz=20 friction=0.4"')
    ap.add_argument("--iters", type=int, default=4, help="PGS iterations")
    ap.add_argument("--seed", type=int, default=1, help="scene seed")
    ap.add_argument("--budget", type=float, default=DEFAULT_BUDGET,
                    help="allowed relative error of the step against float64 (0.01 = 1%%)")
    ap.add_argument("--out", default="build/analyze", help="parent directory of the analysis directory")
    return ap.parse_args(argv)


def analyze(args: argparse.Namespace) -> dict[str, Any]:
    if not 0 < args.budget < 1:
        raise ValueError(f"BUDGET must be in (0, 1), got {args.budget}")
    frame, label = scenes.load_scene(args.scene, args.scene_args, args.seed)
    print(frame.summary(), flush=True)
    t0 = time.perf_counter()
    problem = problem_of(frame, args.iters)
    fmt, err, ranges = kernel_format(problem, args.budget)
    print(f"kernel format: {fmt.name} ({fmt.width} bits), error {err:.3g} ({time.perf_counter() - t0:.1f} s)",
          flush=True)
    storage = fa.storage_formats(problem, ranges, args.budget)
    alone = {g: f for g, (f, _) in storage.items()}
    chosen, mixed = fa.fit_mixed(problem, fmt, alone, args.budget)
    named = {name: problem.error(problem.step(f)) for name, f in (("fp32", FP32), ("fp16", FP16))}
    return {
        "scene": {"scene": label, "bodies": frame.num_bodies, "manifolds": frame.num_manifolds,
                  "iterations": args.iters, "error budget (relative, see models/sizing/format_analyzer.py)": args.budget},
        "ranges (smallest and largest non-zero magnitude; exponent bits that hold them)": {
            r.group: f"{r.min_abs:.3g} .. {r.max_abs:.3g}, {r.zeros}/{r.values} zeros -> {r.exp_bits} exponent bits"
            for r in ranges},
        "one format for the kernel (FORMAT=auto)": {
            "format": fmt.name, "width (bits)": fmt.width, "error": err,
            "fp32 error (for comparison)": named["fp32"], "fp16 error (for comparison)": named["fp16"]},
        "storage format per group, alone (others exact, float64 arithmetic)": {
            g: (f"{f.name} ({f.width} bits), error {e:.3g}" if g in storage else "none within the budget")
            for g, (f, e) in ((g, storage.get(g, (fmt, float("nan")))) for g in fa.GROUPS)},
        "storage formats together, arithmetic in the kernel format (a proposal: the RTL stores one format)": {
            **{g: f.name for g, f in chosen.items()},
            "error": mixed, "within budget": str(mixed <= args.budget),
            **{f"{rec} record bits (unpadded)": bits for rec, bits in fa.record_bits(chosen, fmt).items()},
            **{f"{rec} record bits in {fmt.name} (unpadded)": bits
               for rec, bits in fa.record_bits({}, fmt).items()}},
    }


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        sections = analyze(args)
    except (ValueError, FrameError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    for name, rows in sections.items():
        print(f"-- {name}")
        for k, v in rows.items():
            print(f"  {k}: {format_value(v)}")
    out = Path(args.out) / f"{sections['scene']['scene']}-s{args.seed}"
    out.mkdir(parents=True, exist_ok=True)
    (out / "analysis.json").write_text(json.dumps(sections, indent=1) + "\n")
    print(f"\nanalysis: {out / 'analysis.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
