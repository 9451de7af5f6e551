"""``make stability``: the hard-case suite (``models/stability.py``) over number formats and iteration counts.

Runs every case closed loop (pybullet collision detection, the bit-accurate golden model of each format, which
the RTL kernel matches bit for bit) at 1, 4, 10 and 30 iterations, judges it against the case's thresholds and
writes ``build/stability/stability.md`` (the table), ``stability.csv`` and one plot per case (kinetic energy and
penetration over the steps, ``<case>.png``). Failing rows are findings, reported, not errors: the command exits
non-zero only when a run crashes.

    python -m sim.stability --cases stack20,incline40 --formats fp32,fp16 --iters 4,30 --jobs 2
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from models.closed_loop import LoopResult
from models.number_format import parse_format
from models.stability import CASES, ITERATIONS, Verdict, judge
from sim.report import format_value

FIGURES = ["max penetration (m)", "max drift (m)", "max speed (m/s)", "final max speed (m/s)",
           "final kinetic energy (J)", "NaN/Inf values"]


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(prog="python -m sim.stability", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", default=",".join(CASES), help=f"comma-separated cases ({', '.join(CASES)})")
    ap.add_argument("--formats", default="fp32,fp16,bf16", help="comma-separated number formats")
    ap.add_argument("--iters", default=",".join(map(str, ITERATIONS)), help="comma-separated iteration counts")
    ap.add_argument("--steps", type=int, default=0, help="override every case's step count (0: the case's own)")
    ap.add_argument("--jobs", type=int, default=2, help="parallel runs")
    ap.add_argument("--out", default="build/stability", help="output directory")
    return ap.parse_args(argv)


def _run_one(case_name: str, fmt_name: str, iterations: int, steps: int) -> tuple[Verdict, dict[str, list[float]], float]:
    t0 = time.perf_counter()
    case = CASES[case_name]
    result: LoopResult = case.run(parse_format(fmt_name), iterations, steps or None)
    series = {"kinetic energy (J)": result.kinetic_energy.tolist(), "max penetration (m)": result.max_penetration.tolist()}
    return judge(case, result), series, time.perf_counter() - t0


def plan(args: argparse.Namespace) -> list[tuple[str, str, int]]:
    cases = [c.strip() for c in args.cases.split(",") if c.strip()]
    unknown = [c for c in cases if c not in CASES]
    if unknown:
        raise ValueError(f"unknown case(s) {', '.join(unknown)} (known: {', '.join(CASES)})")
    formats = [parse_format(f.strip()).name for f in args.formats.split(",") if f.strip()]
    try:
        iters = [int(x) for x in args.iters.split(",") if x.strip()]
    except ValueError:
        raise ValueError(f"ITERS must be comma-separated integers, got {args.iters!r}") from None
    if not iters or min(iters) < 1 or args.steps < 0 or args.jobs < 1:
        raise ValueError("iterations and jobs must be >= 1, steps >= 0")
    return [(c, f, i) for c in cases for f in formats for i in iters]


def table(verdicts: list[Verdict]) -> list[str]:
    lines = ["| case | format | iterations | " + " | ".join(FIGURES) + " | outcome |",
             "|---" * (len(FIGURES) + 4) + "|"]
    for v in verdicts:
        cells = [format_value(v.figures[k]) for k in FIGURES]
        outcome = "pass" if v.passed else "FAIL: " + "; ".join(v.failures)
        lines.append(f"| {v.case} | {v.format} | {v.iterations} | " + " | ".join(cells) + f" | {outcome} |")
    return lines


def plot_case(case: str, runs: list[tuple[Verdict, dict[str, list[float]]]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for v, series in runs:
        for ax, key in zip(axes, ("kinetic energy (J)", "max penetration (m)")):
            ax.plot(np.arange(1, len(series[key]) + 1), series[key], label=f"{v.format} {v.iterations} it",
                    linestyle="-" if v.passed else "--")
    for ax, key in zip(axes, ("kinetic energy (J)", "max penetration (m)")):
        ax.set_xlabel("step (measured)")
        ax.set_ylabel(key)
        ax.set_yscale("symlog", linthresh=1e-3)
        ax.grid(True, alpha=0.3)
    axes[1].legend(fontsize=7, ncol=2)
    fig.suptitle(f"{case}: {CASES[case].description} (dashed: fails its thresholds)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        runs = plan(args)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    out = Path(args.out)
    results: list[tuple[Verdict, dict[str, list[float]]]] = []
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        futures = [pool.submit(_run_one, c, f, i, args.steps) for c, f, i in runs]
        for n, fut in enumerate(futures, 1):
            verdict, series, sec = fut.result()
            results.append((verdict, series))
            status = "pass" if verdict.passed else "FAIL " + "; ".join(verdict.failures)
            print(f"[{n}/{len(runs)}] {verdict.case} {verdict.format} {verdict.iterations} it: {status} ({sec:.1f} s)",
                  flush=True)
    out.mkdir(parents=True, exist_ok=True)
    verdicts = [v for v, _ in results]
    lines = ["# Hard cases: closed loop, golden model (bit-identical to the RTL kernel)", ""]
    lines += [f"- **{c.name}** ({c.steps} steps after {c.warmup_steps} unmeasured): {c.description}; thresholds "
              f"{_thresholds(c.thresholds)}" for c in CASES.values() if any(v.case == c.name for v in verdicts)]
    lines += ["", *table(verdicts), ""]
    (out / "stability.md").write_text("\n".join(lines))
    with (out / "stability.csv").open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["case", "format", "iterations", *FIGURES, "passed", "failures"])
        for v in verdicts:
            w.writerow([v.case, v.format, v.iterations, *(v.figures[k] for k in FIGURES), v.passed,
                        "; ".join(v.failures)])
    for case in dict.fromkeys(v.case for v in verdicts):
        plot_case(case, [(v, s) for v, s in results if v.case == case], out / f"{case}.png")
    print("\n".join(table(verdicts)))
    print(f"\n{sum(v.passed for v in verdicts)}/{len(verdicts)} runs pass their thresholds "
          f"({time.perf_counter() - t0:.0f} s); table: {out / 'stability.md'}, plots: {out}/<case>.png")
    return 0


def _thresholds(t: Any) -> str:
    parts = [f"{k.replace('_', ' ')} {v:g}" for k, v in vars(t).items() if v not in (0.0, float("inf"))]
    return ", ".join(parts) + ", no NaN/Inf"


if __name__ == "__main__":
    sys.exit(main())
