"""``make stability``: the hard-case suite (``models/closed_loop/hard_cases.py``) over number formats and iteration
counts.

Runs every case closed loop (pybullet collision detection, the bit-accurate golden model of each format, which
the RTL kernel matches bit for bit) at 1, 4, 10 and 30 iterations, judges it on physical quantities against the
case's thresholds (``models/closed_loop/hard_cases.py``: penetration against Bullet's slop, each body's largest
excursion and path length, speeds net of the stored g*dt; every limit with its reason), under each remedy
(``--remedies``: cold = Bullet GPU, warm = Bullet 2's warm start, warm+subN = warm start and N substeps, ...+soft... =
Box2D v3's soft step, models/golden/soft_contact.py, every solve and relax call counted; ...shock... = shock
propagation, models/golden/shock_propagation.py; each priced in kernel cycles per step by the cycle model) and writes
``build/stability/stability.md`` (the limits and the table), ``stability.csv`` and one plot per case (kinetic energy and
penetration over the steps, ``<case>.png``). Failing rows are findings, reported, not errors: the command exits non-zero
only when a run crashes.

The runs are independent points on ``--executor`` (``sim/parallel/executor.py``: ``local:N``, the default
``local:<jobs>``, ``dask:local:N`` or ``dask:tcp://host:port``); each finished run is recorded in
``<out>/.points/stability.jsonl`` and a rerun after a failure resumes from them (the file is removed once the table is
written).

    python -m sim.stability --cases stack20,incline40 --formats fp32,fp16 --iters 4,30 --jobs 2
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from models.formats.number_format import parse_format
from models.closed_loop.hard_cases import CASES, FIGURES, ITERATIONS, LIMITS, REMEDIES, Thresholds, Verdict, judge
from sim.compile.artefacts import source_digest
from sim.parallel.executor import parse_executor, run_points
from sim.parallel.point_results import PointLog
from sim.report.run_report import format_value

def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(prog="python -m sim.stability", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", default=",".join(CASES), help=f"comma-separated cases ({', '.join(CASES)})")
    ap.add_argument("--formats", default="fp32,fp16,bf16", help="comma-separated number formats")
    ap.add_argument("--iters", default=",".join(map(str, ITERATIONS)),
                    help="comma-separated iteration counts per step (a remedy's substeps share them)")
    ap.add_argument("--remedies", default="cold,warm,warm+sub2,warm1+soft15z1+sub2+relax,warm+sub4+shocklrh",
                    help=f"comma-separated remedies ({', '.join(REMEDIES)}; models/closed_loop/hard_cases.py REMEDIES)")
    ap.add_argument("--steps", type=int, default=0, help="override every case's step count (0: the case's own)")
    ap.add_argument("--jobs", type=int, default=2, help="parallel runs (the default executor local:<jobs>)")
    ap.add_argument("--executor", default="", help="local:N, dask:local:N or dask:tcp://host:port (sim/parallel/executor.py)")
    ap.add_argument("--out", default="build/stability", help="output directory")
    return ap.parse_args(argv)


@dataclass(frozen=True)
class StabilityPoint:
    """One closed-loop run of a hard case (``sim.parallel.executor`` point): the verdict and the plotted series come back."""

    case: str
    fmt: str
    iterations: int
    steps: int
    sources: str  # sim.compile.artefacts.source_digest() when planned
    remedy: str = "cold"

    @property
    def key(self) -> str:
        return f"{self.case}-{self.fmt}-it{self.iterations}-steps{self.steps}-{self.remedy}-{self.sources}"

    @property
    def command(self) -> str:
        return (f".venv/bin/python -m sim.stability --cases {self.case} --formats {self.fmt} --iters {self.iterations}"
                f" --remedies {self.remedy} --steps {self.steps} --jobs 1")

    def run(self) -> dict[str, Any]:
        t0 = time.perf_counter()
        case = CASES[self.case]
        result, path = case.run(parse_format(self.fmt), self.iterations, self.steps or None,
                                remedy=REMEDIES[self.remedy])
        series = {"kinetic energy (J)": result.kinetic_energy.tolist(),
                  "max penetration (m)": result.max_penetration.tolist()}
        return {"verdict": asdict(judge(case, result, path, self.iterations)), "series": series,
                "warm start": result.extra["warm start"], "seconds": time.perf_counter() - t0}


def plan(args: argparse.Namespace) -> list[StabilityPoint]:
    cases = [c.strip() for c in args.cases.split(",") if c.strip()]
    unknown = [c for c in cases if c not in CASES]
    if unknown:
        raise ValueError(f"unknown case(s) {', '.join(unknown)} (known: {', '.join(CASES)})")
    formats = [parse_format(f.strip()).name for f in args.formats.split(",") if f.strip()]
    remedies = [r.strip() for r in args.remedies.split(",") if r.strip()]
    bad = [r for r in remedies if r not in REMEDIES]
    if bad or not remedies:
        raise ValueError(f"unknown remedy(ies) {', '.join(bad) or '(none given)'} (known: {', '.join(REMEDIES)})")
    try:
        iters = [int(x) for x in args.iters.split(",") if x.strip()]
    except ValueError:
        raise ValueError(f"ITERS must be comma-separated integers, got {args.iters!r}") from None
    if not iters or min(iters) < 1 or args.steps < 0 or args.jobs < 1:
        raise ValueError("iterations and jobs must be >= 1, steps >= 0")
    parse_executor(args.executor or f"local:{args.jobs}")
    digest = source_digest()
    return [StabilityPoint(c, f, i, args.steps, digest, r) for c in cases for f in formats for i in iters
            for r in remedies]


def table(verdicts: list[Verdict]) -> list[str]:
    lines = ["| case | format | iterations | remedy | " + " | ".join(FIGURES) + " | outcome |",
             "|---" * (len(FIGURES) + 5) + "|"]
    for v in verdicts:
        cells = [format_value(v.figures[k]) for k in FIGURES]
        outcome = "pass" if v.passed else "FAIL: " + "; ".join(v.failures)
        lines.append(f"| {v.case} | {v.format} | {v.iterations} | {v.remedy} | " + " | ".join(cells)
                     + f" | {outcome} |")
    return lines


def remedy_table(verdicts: list[Verdict]) -> list[str]:
    """Which remedy makes which case pass, and at what price: one row per case, format and iteration count, one
    column per remedy (pass/FAIL, kernel cycles per step on the cycle model, manifold-passes per step)."""
    remedies = list(dict.fromkeys(v.remedy for v in verdicts))
    rows: dict[tuple[str, str, int], dict[str, Verdict]] = {}
    for v in verdicts:
        rows.setdefault((v.case, v.format, v.iterations), {})[v.remedy] = v
    lines = ["| case | format | iterations | " + " | ".join(remedies) + " |", "|---" * (len(remedies) + 3) + "|"]
    for (case, fmt, it), by in rows.items():
        cells = [(f"{'pass' if by[r].passed else 'FAIL'} ({by[r].figures['kernel cycles per step']:,.0f} cycles, "
                  f"{by[r].figures['passes per step']:.0f} passes)") if r in by else "" for r in remedies]
        lines.append(f"| {case} | {fmt} | {it} | " + " | ".join(cells) + " |")
    return lines


def warm_start_table(runs: list[tuple[Verdict, dict[str, int]]]) -> list[str]:
    """Per warm-started run, the points that inherited an impulse, those that started from zero, and every dropped
    entry by its reason (``models.golden.warm_start.WarmStartReport``), over all steps of the run."""
    warm = [(v, r) for v, r in runs if r.get("matched points", 0) or any(k.startswith("dropped") for k in r)]
    if not warm:
        return []
    keys = list(dict.fromkeys(k for _, r in warm for k in r))
    return ["Warm-start matching over each run (points; a manifold that no longer exists counts once):", "",
            "| case | format | iterations | remedy | " + " | ".join(keys) + " |", "|---" * (len(keys) + 4) + "|",
            *(f"| {v.case} | {v.format} | {v.iterations} | {v.remedy} | " + " | ".join(str(r.get(k, 0)) for k in keys)
              + " |" for v, r in warm)]


def plot_case(case: str, runs: list[tuple[Verdict, dict[str, list[float]]]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for v, series in runs:
        for ax, key in zip(axes, ("kinetic energy (J)", "max penetration (m)")):
            ax.plot(np.arange(1, len(series[key]) + 1), series[key], label=f"{v.format} {v.iterations} it {v.remedy}",
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
    t0 = time.perf_counter()
    log = PointLog(out / ".points" / "stability.jsonl")
    done = run_points(runs, parse_executor(args.executor or f"local:{args.jobs}"), log, label="stability")
    if done.failures:
        for failure in done.failures:
            print(failure.describe(), file=sys.stderr)
        print(f"error: {len(done.failures)} of {len(runs)} runs crashed (each with the command that reproduces it "
              f"above); a rerun resumes from the {len(done.rows)} finished ({log.path})", file=sys.stderr)
        return 1
    results: list[tuple[Verdict, dict[str, list[float]]]] = []
    matching: list[tuple[Verdict, dict[str, int]]] = []
    for n, row in enumerate(done.ordered(runs), 1):
        verdict, series = Verdict(**row["verdict"]), row["series"]
        results.append((verdict, series))
        matching.append((verdict, row.get("warm start", {})))
        status = "pass" if verdict.passed else "FAIL " + "; ".join(verdict.failures)
        print(f"[{n}/{len(runs)}] {verdict.case} {verdict.format} {verdict.iterations} it {verdict.remedy}: {status} "
              f"({row['seconds']:.1f} s)", flush=True)
    out.mkdir(parents=True, exist_ok=True)
    verdicts = [v for v, _ in results]
    lines = ["# Hard cases: closed loop, golden model (bit-identical to the RTL kernel)", ""]
    steps = args.steps or None
    lines += [f"- **{c.name}** ({steps or c.steps} steps after {c.warmup_steps} unmeasured): {c.description}; "
              f"thresholds {_thresholds(c.thresholds(steps))}" for c in CASES.values()
              if any(v.case == c.name for v in verdicts)]
    lines += ["", *limits_table(), "", "Which remedy passes (kernel cycles per step: models/timing/cycle_model.py, the "
              "streaming kernel on zcu102, every kernel call of the step):", "", *remedy_table(verdicts), "",
              *table(verdicts), "", *warm_start_table(matching), ""]
    (out / "stability.md").write_text("\n".join(lines))
    with (out / "stability.csv").open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["case", "format", "iterations", "remedy", *FIGURES, "passed", "failures"])
        for v in verdicts:
            w.writerow([v.case, v.format, v.iterations, v.remedy, *(v.figures[k] for k in FIGURES), v.passed,
                        "; ".join(v.failures)])
    for case in dict.fromkeys(v.case for v in verdicts):
        plot_case(case, [(v, s) for v, s in results if v.case == case], out / f"{case}.png")
    log.remove()
    if (out / ".points").is_dir() and not any((out / ".points").iterdir()):
        (out / ".points").rmdir()
    print("\n".join(remedy_table(verdicts) + [""] + table(verdicts)))
    print(f"\n{sum(v.passed for v in verdicts)}/{len(verdicts)} runs pass their thresholds "
          f"({time.perf_counter() - t0:.0f} s); table: {out / 'stability.md'}, plots: {out}/<case>.png")
    return 0


def limits_table() -> list[str]:
    """The limits every case is judged with, each with its reason (``models.closed_loop.hard_cases.LIMITS``)."""
    return ["| limit | value | reason |", "|---|---|---|",
            *(f"| {name} | {limit} | {limit.reason} |" for name, limit in LIMITS.items())]


def _thresholds(t: Thresholds) -> str:
    shared = list(LIMITS.values())
    return ", ".join(f"{name.replace('_', ' ')} {limit}" + ("" if limit in shared else f" ({limit.reason})")
                     for name, limit in t.items()) + ", no NaN/Inf"


if __name__ == "__main__":  # run the imported module: its points then pickle by reference (remote workers import it)
    from sim import stability as stability_module

    sys.exit(stability_module.main())
