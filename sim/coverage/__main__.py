"""``python -m sim.coverage``: build, run the regression (or reuse its last coverage files), summarize."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from sim import coverage
from sim.coverage.build import COVERAGE_ROOT
from sim.coverage.data import merge, parse
from sim.coverage.report import write_report
from sim.coverage.runs import previous_results, run_all


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m sim.coverage", description=coverage.__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--jobs", type=int, default=2, help="harness runs in parallel")
    ap.add_argument("--out", default=str(COVERAGE_ROOT), help="build and report directory")
    ap.add_argument("--cases", default="", help="comma-separated case labels (default: all, and the register test)")
    ap.add_argument("--report-only", action="store_true",
                    help="no build, no run: summarize the coverage.dat files the last runs left")
    args = ap.parse_args(argv)
    out = Path(args.out)
    labels = [c for c in args.cases.split(",") if c]
    results = previous_results(out) if args.report_only else run_all(out, args.jobs, labels)
    merged = merge(p for r in results if r.coverage for p in parse(r.coverage.read_text(errors="replace")))
    return write_report(merged, results, out)


if __name__ == "__main__":
    sys.exit(main())
