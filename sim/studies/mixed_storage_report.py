"""Mixed storage with fp32 arithmetic on the streaming kernel with the impulses in the records: what the storage
formats within the budget buy (``python -m sim.studies.mixed_storage_report``; models only, no RTL).

1. The budget: ``--factor`` (10) times fp32's own rounding error against float64 on the same schedule (max |dv|,
   |dw| as ``make sim`` reports it, and max |dx|, |dq|), on the scene the formats are searched on and on the
   scene they are checked on (``models/sizing/mixed_storage.py``).
2. The narrowest storage per field group within it (``search_storage`` on ``--search-scene``; ``--storage``
   gives the formats instead), and its error on ``--scene`` once (with streamed and with derived tangents).
3. The records' bits and 512-bit beats (``models/sizing/mixed_layout.py``), the cycle model's cycles per manifold-pass
   and the resource model's verdict with the format converters counted, beside the fp32 records design.
4. The floors: DDR bytes per manifold-pass (padded to beats, and packed without padding), body load and
   integration, start-up, against the target cycles per manifold-pass.
5. The mixed design's error against the exact reference where one is cached or solved within
   ``--exact-budget`` seconds, else "no exact reference (reason)".

    python -m sim.studies.mixed_storage_report --scene thesis --search-scene thesis --search-scene-args "nx=12 ny=30
    nz=12"
    python -m sim.studies.mixed_storage_report --scene pile --storage "positions=e5m20,velocities=e6m19"
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import json
import sys
import time
from pathlib import Path
from typing import Any, Sequence

from models.sizing import mixed_layout as ml
from models.sizing import mixed_storage as ms
from models.setup.constraints import BodyTable, body_table, setup_constraints
from models.golden.contact_solver import CONTACT_PASS, SolverParams, pass_sequence
from models.timing.prediction import Prediction
from models.timing.cycle_model import predict_job
from models.timing.platforms import DmaPreset, get_preset
from models.golden.integrator import IntegrationParams
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import FP32, NumberFormat, parse_format
from models.scenes.frame_cache import FRAME_CACHE_DIR, load_scene
from models.order.manifold_schedule import make_schedule
from models.exact.solution_error import SolutionError
from sim.fit import resource_model as rm
from sim.compare.exact_error import error_vs_exact, exact_step
from sim.compile.kernel_build import default_window
from sim.report.run_report import print_summary
from sim.compare.exact_error import NoExactReference
from models.timing import platforms

TARGET = 0.7  # cycles per manifold-pass the board-fit target asks of mixed storage


def parse_storage(text: str) -> dict[str, NumberFormat]:
    """``"positions=e5m20,impulses=e6m14"`` -> formats per group (bad names and formats: ValueError)."""
    out: dict[str, NumberFormat] = {}
    for item in filter(None, (s.strip() for s in text.split(","))):
        group, sep, fmt = item.partition("=")
        if not sep or group.strip() not in ml.STORED_GROUPS:
            raise ValueError(f"--storage item {item!r}: expected <group>=<format>, groups: "
                             f"{', '.join(ml.STORED_GROUPS)}")
        stored = parse_format(fmt.strip())
        if not isinstance(stored, NumberFormat):
            raise ValueError(f"--storage item {item!r}: a stored format is eXmY, fp32, fp16 or bf16")
        out[group.strip()] = stored
    return out


def problem_of(scene: str, scene_args: str, seed: int, iters: int, cons_bits: int,
               factor: float) -> tuple[ms.MixedStepProblem, str, BodyTable]:
    """The scene's step on make sim's fp32 schedule, with the budget of ``factor`` times fp32's rounding error;
    its label and fp32's step."""
    frame, label = load_scene(scene, scene_args, seed)
    bodies = body_table(frame)
    cons = setup_constraints(frame, bodies)
    schedule = make_schedule("hazard", cons, bodies.dynamic, default_window(FP32, cons_bits))
    problem = ms.MixedStepProblem(bodies, cons, schedule, SolverParams(iterations=iters),
                                  IntegrationParams(dt=frame.dt, gravity=tuple(frame.gravity)))
    fp32 = problem.step(FP32)
    problem.budget = ms.Budget(problem.state_error(fp32), factor)
    return problem, label, fp32


def fp32_job(problem: ms.MixedStepProblem) -> KernelJob:
    """The fp32 records design of the problem's step (the impulses travelling with the records)."""
    return KernelJob(FP32, problem.bodies.rounded(FP32), problem.cons.rounded(FP32), problem.schedule,
                     problem.params, problem.iparams).impulses_travelling()


def record_shape(job: KernelJob) -> ml.RecordShape:
    return ml.RecordShape(job.impulses_in_records, job.tangents_on_chip, job.inertia_words, job.friction_words)


@dataclasses.dataclass(frozen=True)
class Design:
    """One design's layout, cycles and fit."""

    name: str
    job: KernelJob
    prediction: Prediction
    fit: rm.FitVerdict | rm.NoEstimate  # Yosys's operator figures
    vendor_fit: rm.FitVerdict | rm.NoEstimate  # the published Vitis HLS operator figures where there are
    converters: int


def design(name: str, job: KernelJob, storage: dict[str, NumberFormat], preset: DmaPreset, dma: str) -> Design:
    """``job`` with ``storage`` (none: the kernel's format throughout): its cycles and both fit verdicts."""
    shape = record_shape(job)
    conv = ml.converters(storage, FP32, shape)
    if storage:
        job = job.stored_as(ml.record_bits(storage, FP32, shape))
    cfg = dataclasses.replace(rm.config_for_job(job), converters=conv)

    def fit(source: str) -> rm.FitVerdict | rm.NoEstimate:
        if dma not in platforms.PLATFORMS:
            return rm.NoEstimate(f"no platform behind the DMA preset {dma!r}")
        return rm.fit_or_reason(dataclasses.replace(cfg, operator_source=source), platforms.get_platform(dma))

    return Design(name, job, predict_job(job, preset), fit("yosys"), fit("vendor"), sum(c.count for c in conv))


def layout_rows(d: Design, preset: DmaPreset) -> dict[str, Any]:
    lay = d.job.stream_layout(preset.stream_bits)
    mp = max(d.prediction.manifold_passes, 1)
    return {"contact record bits (512-bit beats)": f"{lay.contact_bits} ({lay.contact_beats})",
            "friction record bits (beats)": f"{lay.friction_bits} ({lay.friction_beats})",
            "body-in / body-out beats (128-bit)": f"{lay.body_in_beats} / {lay.body_out_beats}",
            "format converters (words)": d.converters,
            "cycles": d.prediction.cycles, "cycles per manifold-pass": round(d.prediction.cycles / mp, 4),
            "fit (Yosys operators; published vendor operators)":
                f"{rm.short_verdict(d.fit)}; {rm.short_verdict(d.vendor_fit)}",
            "LUT, FF, DSP, BRAM36": d.fit.shares_text() if isinstance(d.fit, rm.FitVerdict) else "no estimate"}


def floor_rows(d: Design, preset: DmaPreset) -> dict[str, Any]:
    """What stops the design: DDR bytes, body load and integration, start-up, per manifold-pass."""
    lay = d.job.stream_layout(preset.stream_bits)
    params, pred = d.job.params, d.prediction
    kinds = [k for k, _ in pass_sequence(params)]
    passes = len(kinds)
    mp = max(pred.manifold_passes, 1)
    rate = preset.ddr_bytes_per_cycle
    writes = sum(lay.impulse_write_bytes(k) for k in kinds)
    padded = (lay.bytes_per_manifold(params) + writes) / passes
    rb = lay.record_bits
    contact_bits, friction_bits = (rb.contact, rb.friction) if rb else (lay.contact_bits, lay.friction_bits)
    dense = (sum(contact_bits if k == CONTACT_PASS else friction_bits for k in kinds) / 8 + writes) / passes
    phases = pred.phases
    load, integ = phases["SOLVE"], phases["DONE"] - phases["INTEG"]
    return {"DDR bytes per manifold-pass, records padded to beats (reads + impulse writes)": round(padded, 2),
            f"its floor (cycles per manifold-pass at {rate:.2f} B/cycle, reads and writes sharing it)":
                round(padded / rate, 4),
            "the same with the records packed without padding (no such DMA)": f"{dense:.2f} B, {dense / rate:.4f}",
            "body load (LOAD to SOLVE) per manifold-pass": round(load / mp, 4),
            "integration (INTEG to DONE) per manifold-pass": round(integ / mp, 4),
            "transfer start-up per manifold-pass (one per pass)": round(preset.startup_cycles * passes / mp, 5),
            f"DDR bytes per manifold-pass {TARGET} cycles allow beside the body streams":
                round(max(TARGET - (load + integ) / mp, 0.0) * rate, 2)}


def state_rows(err: ms.StateError, budget: ms.Budget | None = None) -> dict[str, Any]:
    rows: dict[str, Any] = {"max |dv| (m/s), |dw| (rad/s)": f"{err.dv:.3g} / {err.dw:.3g}",
                            "max |dx| (m), |dq|": f"{err.dx:.3g} / {err.dq:.3g}"}
    if budget is not None:
        rows["budget ratio (<= 1: within)"] = round(budget.ratio(err), 4)
    return rows


def budget_section(problem: ms.MixedStepProblem, label: str) -> dict[str, Any]:
    assert problem.budget is not None
    lim = problem.budget.limits
    return {f"{label}: fp32 vs float64, same schedule ({problem.cons.num_manifolds:,} manifolds)":
                state_rows(problem.budget.own)["max |dv| (m/s), |dw| (rad/s)"] + "; |dx|, |dq| "
                + state_rows(problem.budget.own)["max |dx| (m), |dq|"],
            f"{label}: budget ({problem.budget.factor:g} x; gated {', '.join(problem.budget.parts)})":
                f"|dv| {lim.dv:.3g}, |dw| {lim.dw:.3g}, |dx| {lim.dx:.3g}, |dq| {lim.dq:.3g}"}


def storage_section(search: ms.StorageSearch | None, storage: dict[str, NumberFormat], search_label: str
                    ) -> dict[str, Any]:
    rows: dict[str, Any] = {}
    if search is not None:
        for g in ml.STORED_GROUPS:
            f = search.alone.get(g)
            rows[f"{search_label}: {g} alone (float64 arithmetic)"] = \
                f"{f[0].name} ({f[0].width} bits), ratio {f[1]:.3f}" if f else "none narrower within the budget"
        rows[f"{search_label}: all together, fp32 arithmetic, budget ratio"] = round(search.ratio, 4)
    for g in ml.STORED_GROUPS:
        rows[f"stored format: {g}"] = f"{storage[g].name} ({storage[g].width} bits)" if g in storage else "fp32"
    return rows


def exact_text(err: SolutionError | NoExactReference) -> str:
    if isinstance(err, NoExactReference):
        return str(err)
    return (f"max |dv| {err.max_dv:.4g} m/s (median {err.median_dv:.3g}, p99 {err.p99_dv:.3g}), "
            f"max |dw| {err.max_dw:.4g} rad/s")


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(prog="python -m sim.studies.mixed_storage_report", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="thesis", help="the scene the design is checked on")
    ap.add_argument("--scene-args", default="")
    ap.add_argument("--search-scene", default="", help="the scene the formats are searched on (default: --scene)")
    ap.add_argument("--search-scene-args", default="")
    ap.add_argument("--storage", default="", help='formats per group instead of the search, e.g. "positions=e5m20"')
    ap.add_argument("--factor", type=float, default=ms.DEFAULT_FACTOR, help="budget: this times fp32's error")
    ap.add_argument("--iters", type=int, default=4)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--dma", default="zcu102")
    ap.add_argument("--exact-budget", type=float, default=60.0,
                    help="seconds for the exact reference where none is cached (models/exact/reference.py)")
    ap.add_argument("--out", default="build/mixed_storage")
    return ap.parse_args(argv)


def report(args: argparse.Namespace) -> dict[str, Any]:
    t0 = time.perf_counter()
    if args.iters < 1 or not args.factor > 0:
        raise ValueError(f"--iters must be >= 1 and --factor > 0, got {args.iters}, {args.factor}")
    preset = get_preset(args.dma)
    problem, label, fp32 = problem_of(args.scene, args.scene_args, args.seed, args.iters, preset.stream_bits,
                                      args.factor)
    sections: dict[str, Any] = {"scene": {"checked on": label, "bodies": problem.bodies.num_bodies,
                                          "manifolds": problem.cons.num_manifolds, "iterations": args.iters,
                                          "dma": args.dma}}
    sections["budget"] = budget_section(problem, label)
    search, search_label = None, label
    if args.storage:
        storage = ms.capped(parse_storage(args.storage), FP32)
    else:
        searched = problem
        if args.search_scene:
            searched, search_label, _ = problem_of(args.search_scene, args.search_scene_args, args.seed, args.iters,
                                                preset.stream_bits, args.factor)
            sections["budget"].update(budget_section(searched, search_label))
        search = ms.search_storage(searched, FP32)
        storage = search.chosen
    sections["storage formats (arithmetic fp32)"] = storage_section(search, storage, search_label)
    mixed = problem.step(FP32, storage)
    derived = copy.copy(problem)  # the same float64 reference (its tangents are the frame's planeSpace)
    derived.tangents_on_chip = True
    sections[f"error on {label}, mixed storage, fp32 arithmetic, against float64 (same schedule)"] = {
        **{f"tangents streamed: {k}": v for k, v in state_rows(problem.state_error(mixed), problem.budget).items()},
        **{f"tangents derived on chip: {k}": v
           for k, v in state_rows(derived.state_error(derived.step(FP32, storage)), problem.budget).items()}}
    base = fp32_job(problem)
    designs = [design("fp32 records", base, {}, preset, args.dma),
               design("mixed storage", base, storage, preset, args.dma),
               design("fp32 records, tangents derived", base.tangents_derived(), {}, preset, args.dma),
               design("mixed storage, tangents derived", base.tangents_derived(), storage, preset, args.dma)]
    for d in designs:
        sections[f"design: {d.name} (impulses in the records, {d.job.body_banks} body banks)"] = layout_rows(d, preset)
    for d in designs[1::2]:
        sections[f"floors: {d.name}"] = floor_rows(d, preset)
    best = min(d.prediction.cycles / max(d.prediction.manifold_passes, 1) for d in designs[1::2])
    sections["target"] = {f"{TARGET} cycles per manifold-pass": "reached" if best <= TARGET else
                          f"missed: the best mixed design {best:.4f}"}
    exact = exact_step(problem.bodies, problem.cons, problem.iparams, FRAME_CACHE_DIR, args.exact_budget,
                       problem.params)
    dyn = problem.bodies.dynamic
    sections["against the exact reference"] = {
        "mixed storage, fp32 arithmetic": exact_text(error_vs_exact(mixed, exact, dyn)),
        "fp32 throughout": exact_text(error_vs_exact(fp32, exact, dyn))}
    sections["seconds"] = {"wall": round(time.perf_counter() - t0, 1), "cpu": round(time.process_time(), 1)}
    return sections


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        sections = report(args)
    except (ValueError, KeyError, FileNotFoundError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print_summary(f"mixed storage, fp32 arithmetic: {sections['scene']['checked on']}", sections)
    out = Path(args.out) / sections["scene"]["checked on"]
    out.mkdir(parents=True, exist_ok=True)
    (out / "report.json").write_text(json.dumps(sections, indent=1, default=str) + "\n")
    print(f"\nreport: {out / 'report.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
