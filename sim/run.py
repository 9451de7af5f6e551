"""``make sim``: a scene in, one step through the RTL kernel, cycles and error out.

The run captures (or loads from ``build/frames/``) the scene's busiest frame with pybullet, turns its contacts
into constraints, orders them (hazard schedule by default), and runs the step three ways:

* the RTL kernel (``rtl/pgs_kernel.sv``) in the compiled Verilator harness behind the DMA preset's bandwidth
  model (``sim/drive/kernel_step.py``), its trace and body-out stream compared bit for bit with
* the golden model in the same number format (``models/golden/contact_solver.py``), and
* float64 references: the same schedule and iterations, PGS run until a pass changes little (labelled "float64
  PGS after N contact and N friction passes"), and the exact limit of the scheme (``models/exact/reference.py``,
  cached beside the frame), against which the errors are measured (``sim/compare/exact_error.py``).

The run's findings are typed (``sim.report.run_result.RunResult``) and rendered once
(``sim.report.run_result.sections``): it prints a summary and writes ``report.md``/``report.json`` (and, with
``--waves``, ``waves.fst`` plus a GTKWave save file) into ``build/sim/<scene>-<format>-it<iters>-s<seed>-<dma>/``.
``--frame FILE`` runs a saved frame (``models.formats.frame.save``) instead of the scene's (the run directory is named
after the file).

Bad input (an unknown scene, format or DMA preset, bad parameters, a corrupt, truncated or other-version frame
file) ends the run with one line ``error: ...`` naming the problem and exit status 2; the run directory is
written under a temporary name and appears only once complete (``sim.report.run_report.StagedDirectory``), so a failed
run leaves nothing behind.

    python -m sim.run --scene pile --iters 4 --format fp32 --dma zcu102 --seed 1
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import resource
import sys
import time
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from models import scenes
from models.timing import cycle_model
from models.setup.constraints import BodyTable, ConstraintSet, body_table, setup_constraints
from models.golden.contact_solver import SolverParams, solve, solve_converged
from models.timing.platforms import PRESETS, DmaPreset, get_preset
from models.formats.frame import Frame, FrameError
from models.golden.integrator import IntegrationParams, integrate
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import FLOAT64, FP32, NumberFormat
from models.exact.residual import contact_residual
from models.order.manifold_schedule import SCHEDULE_KINDS, make_schedule, stats
from sim.compare import exact_error
from models.sizing.format_analyzer import auto_format
from sim.drive.harness_run import KernelRunError, text_progress
from sim.compile.kernel_build import COMPILE_PROFILES, DATAPATHS, KernelBuild, check_datapath, default_window
from sim.drive.run_options import (add_kernel_args, check_kernel_args, datapath_options, hardware_format, kernel_job,
                                   kernel_label, load_frame)
from sim.drive.kernel_step import Golden, KernelResult, golden_step, run_kernel_step
from sim.report.run_report import StagedDirectory, print_summary, write_report
from sim.fit.estimate_band import kernel_band
from sim.fit.resource_model import kernel_fit
from sim.fit.timing_estimate import clock_note, kernel_timing
from sim.report.run_result import (AnyRunResult, BitExactness, KernelSpeed, ModelRunResult, RunResult, SceneFacts,
                                   ScheduleFacts, StepErrors, ThesisComparison, VelocityError, WindowFacts, sections,
                                   velocity_error)
from sim.compare.trace_bits import kernel_bodies
from sim.compare import retire_cycles
from models.timing import platforms


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(prog="python -m sim.run", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="pile",
                    help=f"scene name ({', '.join(sorted([*scenes.SCENES, *scenes.ASSET_SCENES]))}), a world file "
                         "(.py, models/scenes/user_world.py) or a URDF file (.urdf: copies dropped on the ground)")
    ap.add_argument("--scene-args", default="", help='scene parameters, e.g. "nx=20 ny=5 nz=20 friction=0.4"')
    ap.add_argument("--frame", default="", help="a frame file (.npz, models.formats.frame.save) to run instead of --scene")
    ap.add_argument("--iters", type=int, default=4, help="PGS iterations per pass type (Bullet GPU: 4)")
    ap.add_argument("--format", default="fp32",
                    help="number format: fp32, fp16, bf16, eXmY, or auto (the narrowest within 1%% error, sim.analyze)")
    ap.add_argument("--dma", default="zcu102", help=f"DMA preset ({', '.join(PRESETS)})")
    ap.add_argument("--seed", type=int, default=1, help="scene seed (jitter) and seed of the random stalls")
    ap.add_argument("--schedule", default="hazard", help=f"manifold order ({', '.join(SCHEDULE_KINDS)})")
    ap.add_argument("--window", type=int, default=0,
                    help="hazard window W in issue slots (0: the kernel's pipeline depth in records)")
    add_kernel_args(ap)
    ap.add_argument("--tangents", choices=TANGENT_SOURCES, default="host",
                    help="streaming kernel: the friction records carry the tangent basis (host), or the kernel derives "
                         "it from the normal (chip: TANGENTS_ON_CHIP build parameter, pgs_friction_pipe_tb; the "
                         "golden model then solves with the derived tangents)")
    ap.add_argument("--stall-permille", type=int, default=0,
                    help="random idle cycles on the input streams and backpressure on the output (per mille)")
    ap.add_argument("--converged-budget", type=float, default=60.0,
                    help="seconds allowed for the float64 PGS run to many passes, reported as 'PGS after N passes' "
                         "(it stops earlier when a pass changes nothing; errors are measured against the exact "
                         "reference, so this iterate is only a labelled comparison)")
    exact_error.add_exact_args(ap)
    ap.add_argument("--no-kernel", action="store_true", help="reference models only (no Verilator)")
    ap.add_argument("--datapath", choices=DATAPATHS, default="rtl",
                    help="the kernel's pipes: rtl, the hand-scheduled ones (rtl/generated/); xls, those Google XLS "
                         "compiled from the same graphs' DSLX (rtl/generated/xls/: the same ports and latencies; fp32 "
                         "and fp16, the default pipes)")
    ap.add_argument("--driver", choices=("harness", "cocotb"), default="harness",
                    help="harness: the compiled Verilator harness; cocotb: the host driver, AXI DMA models and batch "
                         "scoreboard in cocotb on the transaction-level bench (sim/drive/cocotb_step.py)")
    ap.add_argument("--compile-profile", choices=tuple(COMPILE_PROFILES), default="quick",
                    help="how the compiled harness's C++ is built (sim/compile/kernel_build.py COMPILE_PROFILES): quick -O1; "
                         "pgo the same, profile-guided (an instrumented build trained on this run's first cycles, "
                         "then the build from its profile)")
    ap.add_argument("--mode", choices=("rtl", "model"), default="rtl",
                    help="rtl: the whole run, the cycle model beside the RTL; model: the cycle model's estimate alone "
                         "(models/timing/cycle_model.py: no Verilator, no reference solves)")
    ap.add_argument("--waves", action="store_true", help="write waves.fst (first --wave-cycles cycles) + .gtkw")
    ap.add_argument("--wave-cycles", type=int, default=20000, help="cycles of waveform to keep (0: all)")
    ap.add_argument("--out", default="build/sim", help="parent directory of the run directory")
    return ap.parse_args(argv)


CONVERGED_MAX_PASSES = 1_000_000  # the float64 PGS runs until converged, out of budget or hopeless at its rate
TANGENT_SOURCES = ("host", "chip")  # make sim's TANGENTS: who computes the friction tangent basis


def check_args(args: argparse.Namespace) -> None:
    """The arguments that need no frame: raise ValueError naming the first bad one."""
    get_preset(args.dma)
    if args.format.strip().lower() != "auto":
        hardware_format(args.format)
    if args.iters < 1:
        raise ValueError(f"ITERS must be >= 1, got {args.iters}")
    if args.schedule not in SCHEDULE_KINDS:
        raise ValueError(f"unknown schedule {args.schedule!r} (expected one of {', '.join(SCHEDULE_KINDS)})")
    check_kernel_args(args)
    if args.driver == "cocotb" and getattr(args, "impulse_store", "onchip") == "records":
        raise ValueError("DRIVER=cocotb has no DMA model of the impulses in the records: run IMPULSE_STORE=records "
                         "with the compiled harness")
    if getattr(args, "tangents", "host") == "chip" and (args.record_window or args.driver == "cocotb"):
        raise ValueError("TANGENTS=chip is a configuration of the streaming kernel through the compiled harness (no "
                         "RECORD_WINDOW, DRIVER=harness)")
    if args.format.strip().lower() != "auto":  # FORMAT=auto: the kernel build checks the format it picks
        check_datapath(args.datapath, hardware_format(args.format), datapath_options(args))
    if args.driver == "cocotb" and getattr(args, "compile_profile", "quick") != "quick":
        raise ValueError("COMPILE= is the compiled harness's (DRIVER=harness); the cocotb bench has its own build")
    if args.driver == "cocotb" and (args.record_window or args.body_bits != 128 or args.waves or args.stall_permille):
        raise ValueError("DRIVER=cocotb runs the streaming kernel with 128-bit body streams, without waveforms or "
                         "random stalls (RECORD_WINDOW=0 BODY_BITS=128 WAVES=0; the cycle-level cocotb tests cover "
                         "stalls)")
    for name, value, lo, hi in (("--window", args.window, 0, None),
                                ("--stall-permille", args.stall_permille, 0, 1000),
                                ("--converged-budget", args.converged_budget, 0, None),
                                ("--exact-budget", args.exact_budget, 0, None),
                                ("--wave-cycles", args.wave_cycles, 0, None)):
        if not (value >= lo and (hi is None or value <= hi)) or not math.isfinite(value):
            raise ValueError(f"{name} must be {'in ' + str(lo) + '..' + str(hi) if hi else '>= ' + str(lo)}, "
                             f"got {value}")


def _error(ours: BodyTable, ref: BodyTable, dyn: np.ndarray) -> VelocityError:
    return velocity_error(ours, ref.linear_velocity, ref.angular_velocity, dyn)


class Timer:
    """Wall and CPU seconds of each stage of the run (CPU: this process and the child processes it waited for,
    e.g. the kernel harness; the figure that holds on a loaded machine)."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}
        self.cpu_seconds: dict[str, float] = {}

    def run(self, name: str, fn: Any, *args: Any, **kw: Any) -> Any:
        t0, cpu0 = time.perf_counter(), _cpu_s()
        out = fn(*args, **kw)
        self.seconds[name] = time.perf_counter() - t0
        self.cpu_seconds[name] = _cpu_s() - cpu0
        print(f"{name}: {self.seconds[name]:.2f} s ({self.cpu_seconds[name]:.2f} s CPU)", flush=True)
        return out


def _cpu_s() -> float:
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def kernel_speed(res: KernelResult, job: KernelJob, preset: DmaPreset, sched_bubbles: int,
                 driver: str = "harness") -> KernelSpeed:
    """Speed, stream traffic and the roofline's floors of a kernel run."""
    r = res.registers
    mp = job.manifold_passes
    total_bytes = sum(res.stream_bytes.values())
    capped = math.isfinite(preset.ddr_bytes_per_cycle)
    cons_beats = res.stream_bytes["constraints"] // (preset.stream_bits // 8)
    floors = {"DDR bandwidth": total_bytes / preset.ddr_bytes_per_cycle if capped else 0.0,
              "constraint stream port": float(cons_beats),
              f"compute (II=1, {job.lanes} lane{'s' if job.lanes > 1 else ''})": job.compute_floor_cycles}
    return KernelSpeed(
        job.fmt.name, preset.describe(), res.cycles, mp, int(r["stalls"]), int(r["bubbles"]), sched_bubbles,
        res.stream_bytes["body_in"] + res.stream_bytes["constraints"], res.stream_bytes["body_out"],
        res.stream_bytes["constraints"] // max(job.manifolds, 1),
        total_bytes / (res.cycles * preset.ddr_bytes_per_cycle) if capped else None, res.sim_cycles_per_s,
        r["wall_s"], res.build_seconds, floors,
        "cocotb (transaction-level bench)" if driver == "cocotb" else "compiled harness", r.get("cpu_s"))


def thesis_comparison(res: KernelResult | None, job: KernelJob, frame: Frame, seconds: dict[str, float],
                      clock: tuple[float, str] = (0.0, "")) -> ThesisComparison:
    """The thesis's figures beside this run's, its latency at ``clock`` (hertz and why: timing_estimate.clock_note)."""
    return ThesisComparison(job.fmt.name, job.manifolds, job.params.iterations, job.manifold_passes,
                            None if res is None else res.cycles, dict(frame.meta.get("pybullet_timing_s") or {}),
                            frame.meta.get("solver", {}).get("numSolverIterations", "?"), seconds, *clock)


def run(args: argparse.Namespace, run_dir: Path) -> tuple[AnyRunResult, KernelBuild | None]:
    """The run's result, with every file written into ``run_dir``; returns it and the kernel build (None with
    --no-kernel or MODE=model)."""
    check_args(args)
    preset = get_preset(args.dma)
    auto = args.format.strip().lower() == "auto"
    fmt = None if auto else hardware_format(args.format)
    timer = Timer()
    frame, label = timer.run("frame load/capture", load_frame, args)
    print(frame.summary(), flush=True)
    if fmt is None:  # FORMAT=auto: the narrowest single format within the analyzer's error budget
        fmt = timer.run("format analysis (FORMAT=auto)", auto_format, frame, args.iters)
    order = "" if args.schedule == "hazard" else f"-{args.schedule}"
    order += kernel_label(args)
    name = f"{label}-{'auto-' if auto else ''}{fmt.name}-it{args.iters}-s{args.seed}-{args.dma}{order}"

    bodies = body_table(frame)
    cons = timer.run("constraint setup", setup_constraints, frame, bodies)
    window = args.window or default_window(fmt, preset.stream_bits, bool(args.shared_datapath), args.record_window > 0)
    schedule = timer.run(f"{args.schedule} schedule", make_schedule, args.schedule, cons, bodies.dynamic, window)
    sched_stats = timer.run("schedule statistics", stats, args.schedule, schedule, cons, bodies.dynamic, window)
    print(sched_stats.describe(), flush=True)
    params = SolverParams(iterations=args.iters)
    ip = IntegrationParams(dt=frame.dt, gravity=tuple(frame.gravity))
    job = kernel_job(KernelJob(fmt, bodies.rounded(fmt), cons.rounded(fmt), schedule, params, ip), args)
    if args.mode == "model" or not args.no_kernel:
        cycle_model.check_body_beats(job, preset, args.body_bits)  # a body beat the model cannot take: before the build
    if args.mode == "model":  # MODE=model: the cycle model's estimate, the golden model's errors vs the exact reference
        golden = timer.run(f"{fmt.name} golden model solve + integrate", golden_step, job)
        ref = timer.run("float64 reference solve + integrate", _solve_and_integrate, bodies, cons, schedule, params, ip)
        exact = timer.run("exact reference (solve or cache)", exact_error.exact_step, bodies, cons, ip,
                          exact_error.reference_dir(args), args.exact_budget, params)
        timing = kernel_timing(job, args.dma, args.body_bits)
        return ModelRunResult(name, label, frame.num_bodies, frame.num_manifolds, sched_stats.describe(),
                              preset.describe(), at_estimated_clock(model_section(job, preset, body_bits=args.body_bits)[0],
                                                                    timing, preset.clock_hz),
                              fit=kernel_fit(job, args.dma, args.body_bits, advise_adders=args.datapath == "rtl"),
                              band=kernel_band(job, args.dma, args.body_bits),
                              timing=timing,
                              errors=exact_error.exact_errors(exact, golden.final, ref, None, bodies.dynamic),
                              error_source=f"{fmt.name} golden model"), None

    ref = timer.run("float64 reference solve + integrate", _solve_and_integrate, bodies, cons, schedule, params, ip)
    golden = timer.run(f"{fmt.name} golden model solve + integrate", golden_step, job)
    conv = timer.run("converged float64 solve", solve_converged, bodies, cons, schedule, FLOAT64,
                     max_passes=CONVERGED_MAX_PASSES, time_budget_s=args.converged_budget)
    exact = timer.run("exact reference (solve or cache)", exact_error.exact_step, bodies, cons, ip,
                      exact_error.reference_dir(args), args.exact_budget, params)

    res: KernelResult | None = None
    kb: KernelBuild | None = None
    if not args.no_kernel:
        kb = dataclasses.replace(KernelBuild.for_job(job, preset, args.waves, args.body_bits, args.datapath),
                                 compile_profile=args.compile_profile)
        print(f"kernel: {kb.name} ({'building, first time a few minutes' if not _built(kb) else 'built'})", flush=True)
        progress = text_progress(job.manifold_passes)
        waves = run_dir / "waves.fst" if args.waves else None
        if args.driver == "cocotb":
            from sim.drive.cocotb_step import run_cocotb_step

            res, kb = timer.run("RTL kernel through cocotb (build, run, compare)", run_cocotb_step, job, preset,
                                run_dir, args.seed, golden, label, args.schedule, args.datapath)
        else:
            res = timer.run("RTL kernel in Verilator (build, run, compare)", run_kernel_step, job, preset, run_dir,
                            args.seed, args.stall_permille, args.stall_permille, progress, golden=golden,
                            waves=waves, wave_cycles=args.wave_cycles, keep_trace=True, body_bits=args.body_bits,
                            compile_profile=args.compile_profile, datapath=args.datapath)
        print(file=sys.stderr)

    rtl_ours = res is not None and res.bit_exact  # the kernel's own numbers (identical to the golden model's)
    ours = kernel_bodies(run_dir, job, kb) if rtl_ours else golden.final
    source = "RTL kernel" if rtl_ours else f"{fmt.name} golden model"
    errors = step_errors(source, ours, StepInputs(frame, bodies, cons, schedule, params, ip), fmt, golden, ref, conv,
                         exact)
    timing = kernel_timing(job, args.dma, args.body_bits)
    result = RunResult(
        name,
        SceneFacts(label, frame.num_bodies, int(bodies.dynamic.sum()), frame.num_manifolds, frame.num_points_total,
                   frame.meta.get("step", "?"), args.seed),
        ScheduleFacts(args.schedule, window, sched_stats.slots, sched_stats.bubbles, sched_stats.wrap_conflicts,
                      golden.solved.levels, job.manifold_passes),
        errors,
        thesis_comparison(res, job, frame, {
            "float64 reference (numpy)": timer.seconds["float64 reference solve + integrate"],
            f"{fmt.name} golden model (numpy)": timer.seconds[f"{fmt.name} golden model solve + integrate"]},
            clock_note(timing, preset.clock_hz)),
        timer.seconds)
    result.fit = kernel_fit(job, args.dma, args.body_bits, advise_adders=args.datapath == "rtl")
    result.band = kernel_band(job, args.dma, args.body_bits)
    result.timing = timing
    if res is not None:
        cmp = res.comparison
        result.bits = BitExactness(cmp.differing_bits, cmp.differing_words, cmp.records, cmp.bodies,
                                   cmp.first_mismatch or "", res.seed)
        if res.cycles:  # a run that failed before ap_done has no speed to report
            result.speed = kernel_speed(res, job, preset, sched_stats.bubbles, args.driver)
        if args.driver == "cocotb":  # its burst buffers serve the streams at once: the ideal DMA bounds it from below
            result.cycle_model, result.model_agrees = model_section(job, get_preset("ideal"), res, args.stall_permille,
                                                                    args.body_bits, bound_only=True)
            result.cycle_model["model: DMA"] = ("ideal, a lower bound of the cocotb bench (its burst buffers serve "
                                                "the streams without the DMA model's start-up and DDR cap)")
        else:
            result.cycle_model, result.model_agrees = model_section(job, preset, res, args.stall_permille,
                                                                    args.body_bits)
        if job.record_window is not None:
            result.window = window_facts(job, preset)
    return result, kb


@dataclasses.dataclass(frozen=True)
class StepInputs:
    """The step as captured (float64): the frame, its bodies and constraints, the order, the parameters."""

    frame: Frame
    bodies: BodyTable
    cons: ConstraintSet
    schedule: np.ndarray
    params: SolverParams
    ip: IntegrationParams


def step_errors(source: str, ours: BodyTable, step: StepInputs, fmt: NumberFormat, golden: Golden, ref: BodyTable,
                conv: Any, exact: exact_error.AnyExactStep) -> StepErrors:
    """The step's velocities (``ours``, from ``source``) against float64 with the same iterations (``ref``), the
    converged solve ``conv``, the exact reference ``exact`` and pybullet's own step; the residuals; the thesis's
    statistic for formats other than fp32."""
    dyn = step.bodies.dynamic
    conv_final = integrate(conv.result.bodies, FLOAT64, step.ip)
    stat: tuple[float | None, float | None] = (None, None)
    if fmt != FP32:  # the thesis's statistic for its fp16 design
        fp32 = golden_step(KernelJob(FP32, step.bodies.rounded(FP32), step.cons.rounded(FP32), step.schedule,
                                     step.params, step.ip))
        stat = thesis_position_statistic(ours, fp32.final, dyn)
    pb = dataclasses.replace(ours, linear_velocity=step.frame.post_linear_velocity,
                             angular_velocity=step.frame.post_angular_velocity)
    return StepErrors(
        source, _error(ours, ref, dyn), _error(ours, conv_final, dyn),
        exact_error.exact_errors(exact, ours, ref, conv_final, dyn),
        (conv.contact_passes, conv.friction_passes), conv.last_change, bool(conv.converged),
        contact_residual(golden.solved.bodies, step.cons, golden.solved.impulses.normal),
        contact_residual(conv.result.bodies, step.cons, conv.result.impulses.normal), _error(ours, pb, dyn), *stat,
        converged_projected=conv.projected)


def model_section(job: KernelJob, preset: DmaPreset, res: KernelResult | None = None,
                  stall_permille: int = 0, body_bits: int = 128,
                  bound_only: bool = False) -> tuple[dict[str, Any], bool | None]:
    """The cycle model's estimate (body streams of ``body_bits``-bit beats) and whether it agrees with the RTL run
    ``res``: every retire cycle and the counters (deterministic streams), or the model as a lower bound (random
    stalls, where the model is one, or ``bound_only``: a bench whose streams the preset bounds from below); None where
    nothing was compared (no run, or a configuration the model does not take)."""
    t0 = time.process_time()
    try:
        pred = cycle_model.predict_job(job, preset, body_bits=body_bits)
    except ValueError as exc:  # a configuration the model does not take: the run's other sections stand
        return {"cycle model": f"none ({exc})"}, None
    seconds = time.process_time() - t0
    if res is None or res.trace is None or stall_permille or bound_only:
        measured = None if res is None or not res.cycles else res.cycles
        bound = None if measured is None or not pred.BOUNDS_RANDOM_RUNS else measured >= pred.cycles
        return retire_cycles.report_section(pred, preset, seconds, measured), bound
    agreement = retire_cycles.compare_run(pred, res, job.slots)
    return retire_cycles.report_section(pred, preset, seconds, agreement=agreement), agreement.ok


def at_estimated_clock(section: dict[str, Any], timing: Any, platform_hz: float) -> dict[str, Any]:
    """The cycle model's section with the latency at the clock the timing estimate supports (``clock_note``) where
    that is not the platform's."""
    hz, why = clock_note(timing, platform_hz)
    cycles = section.get("model: kernel cycles")
    if not isinstance(cycles, int) or hz == platform_hz:
        return section
    return {**section, f"model: latency at {hz / 1e6:.0f} MHz (ms; {why})": cycles / hz * 1e3}


def window_facts(job: KernelJob, preset: DmaPreset) -> WindowFacts:
    """The window kernel's plan and its on-chip bytes against the platform of the DMA preset (if there is one)."""
    from models.sizing import onchip_budget as ob

    plan = job.record_window
    assert plan is not None
    bud = None
    if preset.name in platforms.PLATFORMS:
        bud = ob.budget(platforms.get_platform(preset.name), job.fmt, job.bodies.num_bodies, len(job.slots),
                        plan.lag * plan.lanes, trailing=max(plan.fetch_passes - 1, 1),
                        impulses_resident=not job.impulses_in_records)
    return WindowFacts(plan, plan.fetches(job.params), bud)


def thesis_position_statistic(ours: BodyTable, fp32: BodyTable, dyn: np.ndarray) -> tuple[float, float]:
    """The thesis's accuracy figure: the share of position values within 1% of the fp32 result, and the
    average relative difference (it reported 99.64% and 0.06% for its fp16 design)."""
    x, ref = ours.position[dyn].ravel(), fp32.position[dyn].ravel()
    rel = np.abs(x - ref) / np.maximum(np.abs(ref), 1e-30)
    return float(np.mean(rel <= 0.01)), float(np.mean(rel))


def _solve_and_integrate(bodies: BodyTable, cons: ConstraintSet, schedule: np.ndarray, params: SolverParams,
                         ip: IntegrationParams) -> BodyTable:
    return integrate(solve(bodies, cons, schedule, FLOAT64, params).bodies, FLOAT64, ip)


def _built(kb: KernelBuild) -> bool:
    from sim.compile.verilator_build import BUILD_ROOT

    return (BUILD_ROOT / kb.name / kb.name).exists()


def _write_gtkw(fst: Path, kb: KernelBuild) -> None:
    from sim.drive.gtkwave_save import write_kernel_save_file

    # the compiled harness names its model "pgs_kernel": the design sits one scope below it
    save = write_kernel_save_file(fst, top="pgs_kernel.pgs_kernel", parameters=kb.parameters)
    print(f"waveform: {fst} (open with: gtkwave {save})")


def run_and_report(args: argparse.Namespace) -> tuple[AnyRunResult, KernelBuild | None, Path]:
    """The whole run of ``args``: its result and kernel build, the summary printed and the report written into its
    run directory (returned); a failed run leaves no directory behind."""
    with StagedDirectory(Path(args.out)) as out:
        result, kb = run(args, out.path)
        report = sections(result)
        print_summary(f"pgs-cosim: {result.label}, {args.format}, {args.iters} iterations, {args.dma}", report)
        write_report(out.path, f"pgs-cosim run: {result.label}", report)
        return result, kb, out.commit(result.name)


# make sim's variables and the options of this command they set (the Makefile's sim recipe); WAVES=1 sets --waves
MAKE_SIM_OPTIONS = {"SCENE": "--scene", "SCENE_ARGS": "--scene-args", "ITERS": "--iters", "FORMAT": "--format",
                    "DMA": "--dma", "SEED": "--seed", "MODE": "--mode", "SCHEDULE": "--schedule",
                    "RECORD_WINDOW": "--record-window", "FETCH_PASSES": "--fetch-passes", "LANES": "--lanes",
                    "BODY_BITS": "--body-bits", "DRIVER": "--driver", "IMPULSE_STORE": "--impulse-store",
                    "TANGENTS": "--tangents", "COMPILE": "--compile-profile", "SHARED_DATAPATH": "--shared-datapath",
                    "DATAPATH": "--datapath", "ADD_DSP": "--add-dsp", "INERTIA": "--inertia"}


def make_sim_argv(command: str) -> list[str]:
    """The options of this command that ``make sim VAR=value ...`` passes (``command`` as a reader types it)."""
    words = command.split()
    if words[:2] != ["make", "sim"]:
        raise ValueError(f"not a make sim command: {command!r}")
    argv: list[str] = []
    for word in words[2:]:
        var, eq, value = word.partition("=")
        if not eq or (var not in MAKE_SIM_OPTIONS and var != "WAVES"):
            raise ValueError(f"{command!r}: {word!r} is not one of make sim's variables "
                             f"({', '.join([*MAKE_SIM_OPTIONS, 'WAVES'])})")
        argv += (["--waves"] if value not in ("", "0") else []) if var == "WAVES" else [MAKE_SIM_OPTIONS[var], value]
    return argv


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        result, kb, run_dir = run_and_report(args)
    except (ValueError, FrameError, scenes.SceneError, KernelRunError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if kb is not None and args.waves:
        _write_gtkw(run_dir / "waves.fst", kb)
    print(f"\nreport: {run_dir / 'report.md'} and {run_dir / 'report.json'}")
    return 0 if result.ok else 1


if __name__ == "__main__":
    sys.exit(main())
