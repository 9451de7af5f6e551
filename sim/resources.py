"""``make resources``: Yosys figures of the RTL kernel's operators and units for the resource model.

Every operator alone and the whole units (``--units``) are synthesized for UltraScale+ (``sim/fit/yosys_figures.py``:
the units, the scripts, the parsing), the points spread over ``--executor`` (``sim/parallel/executor.py``); the
figures are printed beside the vendor's published ones and the thesis's, and merged into
``sim/fit/generated/resource_figures.json`` (``--no-write``: not), which the resource model reads.
"""

from __future__ import annotations

import argparse
import sys
import time

from models.formats.number_format import NumberFormat, parse_format
from sim.compile.verilator_build import REPO_ROOT
from sim.fit.resource_model import FIGURES_FILE, VENDOR_OPERATORS, rtl_latency
from sim.fit.timing_estimate import TIMING_FILE
from sim.fit.yosys_figures import (BUILD, CHECK_SLOTS, DELAY_CHECKS, IMPULSE_CHECK, OPERATOR_UNITS, UNITS, ZCU102,
                                   ResourcePoint, delay_check_line, memory_resources, operator_name, prepare_sources,
                                   report, sum_against_whole, timing_lines, unit_result, write_figures, write_timing)
from sim.parallel.executor import parse_executor, run_points

def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m sim.resources", description=__doc__.splitlines()[0])
    ap.add_argument("--formats", default="fp32,fp16,bf16")
    ap.add_argument("--units", default=",".join(UNITS), help="whole units to synthesize (empty: operators only)")
    ap.add_argument("--no-operators", action="store_true", help="skip the per-operator runs")
    ap.add_argument("--no-write", action="store_true", help=f"do not update {FIGURES_FILE.relative_to(REPO_ROOT)}")
    ap.add_argument("--jobs", type=int, default=1, help="Yosys runs at a time (each uses one core)")
    ap.add_argument("--executor", default="", help="local:N (default local:<jobs>), dask:local:N or "
                                                     "dask:tcp://host:port (sim/parallel/executor.py)")
    ap.add_argument("--no-check", action="store_true", help="skip the memory-formula check synthesis")
    args = ap.parse_args(argv)
    fmts = [parse_format(f) for f in args.formats.split(",")]
    units = [UNITS[u] for u in args.units.split(",") if u]
    for fmt in fmts:
        if not isinstance(fmt, NumberFormat):
            raise SystemExit(f"{fmt.name}: a rounded format is needed (fp32, fp16, bf16, eXmY)")
    spec = parse_executor(args.executor or f"local:{max(1, args.jobs)}")
    t0 = time.monotonic()
    prepare_sources(BUILD / "src")  # once here: workers of this checkout then find them up to date
    ops = [] if args.no_operators else list(OPERATOR_UNITS.values())
    points = [ResourcePoint(u.name, f.name) for f in fmts for u in ops + units]
    if not args.no_check:  # the memory check per format; the delay lines' in the first (their width is fixed)
        points += [ResourcePoint(IMPULSE_CHECK.name, f.name) for f in fmts]
        points += [ResourcePoint(u.name, fmts[0].name) for u in DELAY_CHECKS.values()]
    result = run_points(points, spec, label="resources")
    if result.failures:
        for failure in result.failures:
            print(failure.describe(), file=sys.stderr)
        print(f"error: {len(result.failures)} of {len(points)} Yosys runs failed", file=sys.stderr)
        return 1
    done = [unit_result(p, result.rows[p.key]) for p in points]
    if ops:
        print("| format | operator (latency, cycles) | source | LUT | FF | DSP48E2 | Yosys s |")
        print("|---|---|---|---|---|---|---|")
        for r in done:
            if r.unit.name.startswith("op_"):
                name = operator_name(r.unit)
                print(f"| {r.fmt.name} | {name} ({rtl_latency(r.unit.top, r.fmt)}) | Yosys | "
                      f"{r.resources.lut:,.0f} | {r.resources.ff:,.0f} | {r.resources.dsp:,.0f} | {r.seconds:.0f} |")
                for v in VENDOR_OPERATORS.get((name, r.fmt.name), ()):
                    print(f"| {r.fmt.name} | {v.label} ({v.latency}) | {v.source} | {v.resources.lut:,.0f} | "
                          f"{v.resources.ff:,.0f} | {v.resources.dsp:,.0f} | - |")
        print()
    if units:
        print("| format | part | LUT | FF | DSP48E2 | BRAM36 | URAM |")
        print("|---|---|---|---|---|---|---|")
        for fmt in fmts:
            for line in report(fmt, [r for r in done if r.fmt == fmt and r.unit in units]):  # type: ignore[arg-type]
                print(line)
    for line in sum_against_whole(done):
        print(line)
    for r in done:
        if r.unit == IMPULSE_CHECK:
            formula = memory_resources(r.fmt, 0, CHECK_SLOTS).bram36
            print(f"memory check, {r.fmt.name}: pgs_impulse_ram with {CHECK_SLOTS:,} slots: Yosys "
                  f"{r.resources.bram36:g} BRAM36 ({r.resources.lut:g} LUT, {r.seconds:.0f} s), formula {formula:g}")
    for block, unit in DELAY_CHECKS.items():
        for r in (r for r in done if r.unit == unit):
            print(delay_check_line(block, r))
    for line in timing_lines(done):
        print(line)
    if not args.no_write:
        write_figures(done)
        write_timing(done)
        print(f"figures written to {FIGURES_FILE.relative_to(REPO_ROOT)} and {TIMING_FILE.relative_to(REPO_ROOT)}")
    print(f"\nXCZU9EG: {ZCU102.describe()}. Yosys synth_xilinx -family xcup, hierarchy kept: an estimate; timing "
          "closure and the final utilisation need Vivado. Memories computed from their sizes (sim/fit/resource_model.py).")
    print(f"make resources: {time.monotonic() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
