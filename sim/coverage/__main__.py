"""``python -m sim.coverage``: build, run the regression (or reuse its last coverage files), summarize."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from sim import coverage
from sim.coverage.build import COVERAGE_COMPILE_PROFILE, COVERAGE_ROOT
from sim.coverage.configurations import BY_NAME, CONFIGURATIONS, Configuration
from sim.coverage.data import PointKey, add_counts, merge, parse
from sim.coverage.report import summarize, write_report
from sim.coverage.runs import previous_results, run_all
from sim.coverage.waivers import toggle_waivers_for, waivers_for
from sim.compile.kernel_build import COMPILE_PROFILES, PROFILE_GUIDED


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m sim.coverage", description=coverage.__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--jobs", type=int, default=2, help="harness runs in parallel")
    ap.add_argument("--out", default=str(COVERAGE_ROOT), help="build and report directory")
    ap.add_argument("--cases", default="", help="comma-separated case labels (default: all, and the shared runs)")
    ap.add_argument("--configurations", default="",
                    help=f"comma-separated configurations (default: all of {', '.join(BY_NAME)})")
    ap.add_argument("--compile-profile", default=COVERAGE_COMPILE_PROFILE,
                    choices=sorted(set(COMPILE_PROFILES) - PROFILE_GUIDED),
                    help="C++ optimization of the instrumented kernel builds (sim.compile.kernel_build.COMPILE_PROFILES; "
                         "quick: -O1 on the model's fast path, o0: -O0 everywhere; not the profile-guided ones, "
                         "whose training run is a kernel run's own)")
    ap.add_argument("--report-only", action="store_true",
                    help="no build, no run: summarize the coverage.dat files the last runs left")
    args = ap.parse_args(argv)
    out = Path(args.out)
    labels = [c for c in args.cases.split(",") if c]
    names = [c for c in args.configurations.split(",") if c]
    unknown = sorted(set(names) - set(BY_NAME))
    if unknown:
        ap.error(f"unknown configurations {unknown}: expected some of {list(BY_NAME)}")
    results = previous_results(out, names) if args.report_only else \
        run_all(out, args.jobs, labels, names, args.compile_profile)
    configs = [c for c in CONFIGURATIONS if not names or c.name in names]
    counts: dict[Configuration, dict[PointKey, int]] = {c: {} for c in configs}
    for r in results:  # each coverage.dat read once, added to the configurations it counts for
        if r.coverage is None:
            continue
        run = merge(parse(r.coverage.read_text(errors="replace")))
        for c in configs:
            if r.counts_for(c):
                add_counts(counts[c], run)
    summaries = {c: summarize(counts[c], waivers=waivers_for(c), toggle_waivers=toggle_waivers_for(c))
                 for c in configs}
    return write_report(summaries, results, out)


if __name__ == "__main__":
    sys.exit(main())
