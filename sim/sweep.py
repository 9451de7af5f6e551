"""``make sweep``: kernel time against error, over iteration counts and number formats, on one scene.

For every format and iteration count the RTL kernel runs the step in Verilator (``sim.kernel_step``, DMA preset
bandwidth model, trace and body-out compared bit for bit with the golden model) and the kernel's result is
compared with the exact limit of the scheme on the same frame (``models/exact_reference.py``, cached beside the
frame; it depends on no format or schedule; ``sim/exact_error.py``: per-body |dv| and |dw|, max, median and p99;
without an exact reference those columns say ``no exact reference`` and why, and the plot has no points).
Writes ``sweep.csv`` and ``sweep.png`` into ``build/sweep/<scene>-<dma>/``: time per manifold-pass (ns at the
preset's clock, so that scenes of any size and the thesis's figures share one axis) against the maximum velocity
error, with the thesis's ZCU102 fp32/fp16 designs and its GPU and CPU figures marked as vertical lines (their error
on our frame is unknown: the thesis did not measure it).

``--record-window N`` (with ``--lanes L``, ``--fetch-passes``, ``--body-bits``) sweeps the window kernel
(``rtl/pgs_window.sv``) instead of the streaming one; its points are labelled ``<format> window xL`` and go to
``build/sweep/<scene>-<dma>-ring<N>[-lanes<L>][-body<B>]/`` (the options ``make sim`` names its runs by).

``--frame FILE`` sweeps a saved frame (``models.frame.save``) instead of the scene's. Bad input (an unknown scene,
format or DMA preset, bad iteration counts, a corrupt, truncated or other-version frame file) ends the sweep with
one line ``error: ...`` and exit status 2, and the sweep directory appears only once complete
(``sim.report.StagedDirectory``): a failed sweep leaves nothing behind.

    python -m sim.sweep --scene pile --formats fp32,fp16,bf16 --iters 1,2,4,8,16,32
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path
from typing import Any, Sequence

from models import scenes
from models.constraints import body_table, setup_constraints
from models.contact_solver import SolverParams
from models.dma_model import PRESETS, get_preset
from models.frame import FrameError
from models.integrator import IntegrationParams
from models.solution_error import SolutionError
from models.number_format import FLOAT64
from models.schedule import make_schedule
from sim import baselines, exact_error
from sim.analyze import auto_format
from models.kernel_job import KernelJob
from sim.harness_run import KernelRunError
from sim.kernel_build import KernelBuild, default_window
from sim.kernel_step import golden_step, run_kernel_step
from sim.trace_compare import kernel_bodies
from sim.report import StagedDirectory
from sim.run_result import NoExactReference
from sim.run import add_kernel_args, check_kernel_args, hardware_format, kernel_job, kernel_label, load_frame, \
    velocity_error

COLUMNS = ["format", "iterations", "manifolds", "manifold_passes", "cycles", "cycles_per_manifold_pass",
           "ms_at_clock", "ns_per_manifold_pass", "stalls", "bubbles", "bytes_streamed", "differing_bits",
           "max_dv_vs_exact", "max_dw_vs_exact", "median_dv_vs_exact", "p99_dv_vs_exact", "median_dw_vs_exact",
           "p99_dw_vs_exact", "max_dv_vs_float64_same_iters"]


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(prog="python -m sim.sweep", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="pile", help=f"scene name ({', '.join(sorted(scenes.SCENES))})")
    ap.add_argument("--frame", default="", help="a frame file (.npz, models.frame.save) to sweep instead of --scene")
    ap.add_argument("--formats", default="fp32,fp16,bf16",
                    help="comma-separated number formats (fp32, fp16, bf16, eXmY, auto: the analyzer's choice)")
    ap.add_argument("--iters", default="1,2,4,8,16,32", help="comma-separated iteration counts")
    ap.add_argument("--dma", default="zcu102", help=f"DMA preset ({', '.join(PRESETS)})")
    ap.add_argument("--seed", type=int, default=1, help="scene seed")
    exact_error.add_exact_args(ap)
    add_kernel_args(ap)
    ap.add_argument("--out", default="build/sweep", help="parent directory of the sweep directory")
    return ap.parse_args(argv)


def _int_list(text: str, name: str) -> list[int]:
    try:
        values = [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise ValueError(f"{name} must be comma-separated integers, got {text!r}") from None
    if not values or min(values) < 1:
        raise ValueError(f"{name} must be positive integers, got {text!r}")
    return values


def sweep(args: argparse.Namespace, out_dir: Path) -> tuple[list[dict[str, Any]], str]:
    """The sweep's rows, every run's files written under ``out_dir``; returns them and the sweep's name."""
    preset = get_preset(args.dma)
    names = [f.strip() for f in args.formats.split(",") if f.strip()]
    if not names:
        raise ValueError(f"FORMATS names no number format: {args.formats!r}")
    for name in names:  # checked before any work; auto is resolved once the frame is loaded
        if name.lower() != "auto":
            hardware_format(name)
    iter_list = _int_list(args.iters, "ITERS")
    if not args.exact_budget >= 0:
        raise ValueError(f"--exact-budget must be >= 0, got {args.exact_budget}")
    check_kernel_args(args)
    frame, label = load_frame(args)
    print(frame.summary(), flush=True)
    bodies = body_table(frame)
    cons = setup_constraints(frame, bodies)
    ip = IntegrationParams(dt=frame.dt, gravity=tuple(frame.gravity))
    dyn = bodies.dynamic
    formats = [(auto_format(frame, 4), "auto") if n.lower() == "auto" else (hardware_format(n), "") for n in names]
    exact = exact_error.exact_step(bodies, cons, ip, exact_error.reference_dir(args), args.exact_budget)
    rows: list[dict[str, Any]] = []
    for fmt, how in formats:
        schedule = make_schedule("hazard", cons, dyn, default_window(fmt, preset.stream_bits))
        for iters in iter_list:
            params = SolverParams(iterations=iters)
            job = kernel_job(KernelJob(fmt, bodies.rounded(fmt), cons.rounded(fmt), schedule, params, ip), args)
            kb = KernelBuild.for_job(job, preset, body_bits=args.body_bits)
            res = run_kernel_step(job, preset, out_dir / f"{fmt.name}-it{iters}", args.seed, body_bits=args.body_bits)
            ref_final = golden_step(KernelJob(FLOAT64, bodies, cons, schedule, params, ip)).final
            ours = kernel_bodies(out_dir / f"{fmt.name}-it{iters}", job, kb)
            e_exact = exact_error.error_vs_exact(ours, exact, dyn)
            e_same = velocity_error(ours, ref_final.linear_velocity, ref_final.angular_velocity, dyn)
            mp = job.manifold_passes
            kernel = f" window x{args.lanes}" if args.record_window else ""
            row = {"format": (f"{fmt.name} ({how})" if how else fmt.name) + kernel, "iterations": iters,
                   "manifolds": job.manifolds, "manifold_passes": mp,
                   "cycles": res.cycles, "cycles_per_manifold_pass": res.cycles / mp,
                   "ms_at_clock": res.cycles / preset.clock_hz * 1e3,
                   "ns_per_manifold_pass": res.cycles / mp / preset.clock_hz * 1e9,
                   "stalls": int(res.registers["stalls"]), "bubbles": int(res.registers["bubbles"]),
                   "bytes_streamed": sum(res.stream_bytes.values()), "differing_bits": res.comparison.differing_bits,
                   **exact_columns(e_exact), "max_dv_vs_float64_same_iters": e_same.max_dv}
            rows.append(row)
            print(f"{row['format']:>6} {iters:>3} it: {res.cycles:>9,} cycles ({row['cycles_per_manifold_pass']:.2f}/mp), "
                  f"max |dv| vs exact reference {_number(row['max_dv_vs_exact'])} m/s, vs float64 same iterations "
                  f"{row['max_dv_vs_float64_same_iters']:.3e}, differing bits {row['differing_bits']}", flush=True)
            if not res.bit_exact:
                print(f"  NOT bit-exact: {res.comparison.first_mismatch}", flush=True)
    return rows, f"{label}-{args.dma}{kernel_label(args)}"


def exact_columns(e: SolutionError | NoExactReference) -> dict[str, Any]:
    """The csv's columns of the error against the exact reference (``no exact reference (reason)`` without one)."""
    if isinstance(e, NoExactReference):
        return {col: str(e) for col in COLUMNS if col.endswith("_vs_exact")}
    return {"max_dv_vs_exact": e.max_dv, "max_dw_vs_exact": e.max_dw, "median_dv_vs_exact": e.median_dv,
            "p99_dv_vs_exact": e.p99_dv, "median_dw_vs_exact": e.median_dw, "p99_dw_vs_exact": e.p99_dw}


def _number(value: Any) -> str:
    return f"{value:.3e}" if isinstance(value, float) else str(value)


def write_csv(rows: list[dict[str, Any]], path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        w.writerows(rows)


def plot(rows: list[dict[str, Any]], path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 5))
    for fmt in dict.fromkeys(r["format"] for r in rows):
        pts = [r for r in rows if r["format"] == fmt and isinstance(r["max_dv_vs_exact"], float)]
        if not pts:
            continue
        x = [r["ns_per_manifold_pass"] for r in pts]
        y = [max(r["max_dv_vs_exact"], 1e-12) for r in pts]
        ax.plot(x, y, "o-", label=f"RTL kernel {fmt}")
        for r, xi, yi in zip(pts, x, y):
            ax.annotate(str(r["iterations"]), (xi, yi), textcoords="offset points", xytext=(4, 4), fontsize=7)
    per_mp = baselines.THESIS_MANIFOLDS * baselines.THESIS_PASSES
    marks = [(f"{f.label} ({f.cycles_per_manifold_pass:.2f} cyc/mp)", f.ms * 1e6 / per_mp)
             for f in baselines.THESIS_FPGA.values()]
    marks += [("thesis GTX 980", baselines.THESIS_GPU_MS * 1e6 / per_mp),
              ("thesis i7-3770", baselines.THESIS_CPU_MS * 1e6 / per_mp)]
    for (label, x), style in zip(marks, ("--", "-.", ":", ":")):
        ax.axvline(x, linestyle=style, color="grey")
        ax.text(x, 0.03, label, rotation=90, transform=ax.get_xaxis_transform(), fontsize=7, va="bottom",
                ha="right")
    ax.set_xscale("log")
    missing = [r["max_dv_vs_exact"] for r in rows if not isinstance(r["max_dv_vs_exact"], float)]
    if len(missing) < len(rows):  # a log axis needs one point at least
        ax.set_yscale("log")
    ax.set_xlabel("kernel time per manifold-pass (ns; thesis marks: 4 iterations of their 127,000-manifold frame)")
    ax.set_ylabel("max over bodies of |v - v_exact| after the step (m/s)")
    if missing:
        ax.text(0.5, 0.5, missing[0], transform=ax.transAxes, ha="center", wrap=True)
    ax.set_title(title, fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        with StagedDirectory(Path(args.out)) as out:
            rows, name = sweep(args, out.path)
            write_csv(rows, out.path / "sweep.csv")
            plot(rows, out.path / "sweep.png", f"{name}: kernel time against error (iterations annotated)")
            out_dir = out.commit(name)
    except (ValueError, FrameError, KernelRunError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"\nsweep: {out_dir / 'sweep.csv'} and {out_dir / 'sweep.png'}")
    return 0 if all(r["differing_bits"] == 0 for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
