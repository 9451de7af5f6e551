"""What one ``make sim`` run found, typed (:class:`RunResult`, :class:`ModelRunResult`), and its rendering:
:func:`sections` turns a result into the report's sections (title -> quantity -> value), the one form the
console summary and ``report.md`` / ``report.json`` are written from (``sim.report.run_report``)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Optional, Union

import numpy as np

from models.golden.contact_solver import RATE_WINDOW
from models.setup.constraints import BodyTable
from models.sizing.onchip_budget import Budget
from models.kernel.record_window import WindowPlan
from models.exact.solution_error import SolutionError
from models.published import thesis as baselines
from sim.compare.exact_error import ExactErrors, NoExactReference
from sim.fit.estimate_band import BandVerdict, band_basis
from sim.fit.resource_model import FitVerdict, NoEstimate, fit_rows
from sim.fit.timing_estimate import NoTiming, TimingVerdict, histogram_text

VERDICT_SECTION = "verdict (what decides the exit status)"
BITS_SECTION = "bit-exactness (RTL kernel against the golden model, same format)"
MODEL_SECTION = "cycle model (models/timing/cycle_model.py)"
ERROR_SECTION = "error (velocities after the step; dynamic bodies)"
FIT_SECTION = "fit on the platform (resource estimate of this configuration)"
TIMING_SECTION = "timing (estimate: register-to-register depth of the Yosys netlists, sim/fit/timing_estimate.py)"
FitReport = Union[FitVerdict, NoEstimate]
BandReport = Union[BandVerdict, NoEstimate]
TimingReport = Union[TimingVerdict, NoTiming]
Sections = dict[str, dict[str, Any]]


@dataclass(frozen=True)
class VelocityError:
    """Velocities of a step against a reference (dynamic bodies)."""

    max_dv: float  # m/s
    max_dw: float  # rad/s
    relative: float  # max |dv| / max |v| of the reference


def velocity_error(ours: BodyTable, ref_lin: np.ndarray, ref_ang: np.ndarray, dynamic: np.ndarray) -> VelocityError:
    dv = np.abs(ours.linear_velocity[dynamic] - ref_lin[dynamic])
    dw = np.abs(ours.angular_velocity[dynamic] - ref_ang[dynamic])
    scale = max(float(np.max(np.abs(ref_lin[dynamic]), initial=0.0)), 1e-12)
    return VelocityError(float(dv.max(initial=0.0)), float(dw.max(initial=0.0)), float(dv.max(initial=0.0)) / scale)


@dataclass(frozen=True)
class SceneFacts:
    label: str
    bodies: int
    dynamic_bodies: int
    manifolds: int
    contact_points: int
    step: Any  # the captured step (from the frame's metadata; "?" when not recorded)
    seed: int


@dataclass(frozen=True)
class ScheduleFacts:
    kind: str
    window: int  # hazard window W in issue slots
    slots: int  # per pass
    bubbles: int  # per pass
    wrap_hazards: int
    levels: Any  # dependency levels per pass (the golden solve's)
    manifold_passes: int


@dataclass(frozen=True)
class BitExactness:
    differing_bits: int
    differing_words: int
    records: int  # trace records compared
    bodies: int  # body-out records compared
    first_mismatch: str  # "" when none
    stall_seed: int

    @property
    def ok(self) -> bool:
        return self.differing_bits == 0 and not self.first_mismatch


@dataclass(frozen=True)
class KernelSpeed:
    """The RTL kernel's speed, the stream traffic, and the roofline's lower bounds."""

    fmt: str
    dma: str  # the preset, described
    cycles: int
    manifold_passes: int
    stalls: int
    bubbles: int
    schedule_bubbles: int  # per pass
    bytes_in: int  # bodies + constraints
    bytes_out: int
    cons_bytes_per_manifold: int
    ddr_utilisation: Optional[float]  # None: uncapped DDR
    sim_cycles_per_s: float
    wall_s: float
    build_s: float
    floors: dict[str, float]  # lower bound (cycles) by what bounds it
    driver: str = "compiled harness"  # what drove the kernel: the compiled harness or cocotb (make sim DRIVER=)
    cpu_s: Optional[float] = None  # CPU seconds of the kernel run, where the driver measures them

    @property
    def bound(self) -> str:
        return max(self.floors, key=self.floors.__getitem__)


@dataclass(frozen=True)
class WindowFacts:
    """The window kernel's plan, and its on-chip bytes on the DMA preset's platform (None: no platform)."""

    plan: WindowPlan
    fetches: int  # fetches of the records per step
    budget: Optional[Budget] = None


@dataclass(frozen=True)
class StepErrors:
    """The step's velocities against the references (float64 with the same iterations, the exact reference, float64
    PGS run until a pass changes little), the residuals."""

    source: str  # what the errors are of: the RTL kernel, or the golden model when the kernel did not run
    vs_same_iterations: VelocityError  # against float64 with the same schedule and iterations
    vs_converged: VelocityError  # against float64 PGS after the converged solve's passes
    vs_exact: Union[ExactErrors, NoExactReference]
    converged_passes: tuple[int, int]  # contact, friction
    converged_last_change: float
    converged: bool
    residual_after_solve: dict[str, float]  # models.exact.residual.contact_residual
    residual_converged: dict[str, float]
    vs_pybullet: VelocityError
    thesis_within_1pct: Optional[float] = None  # the thesis's fp16 statistic (formats other than fp32)
    thesis_mean_relative: Optional[float] = None
    # contact, friction: passes still needed at the rate of the last models.golden.contact_solver.RATE_WINDOW (0: converged)
    converged_projected: tuple[float, float] = (0.0, 0.0)


@dataclass(frozen=True)
class ThesisComparison:
    fmt: str
    manifolds: int
    iterations: int
    manifold_passes: int
    rtl_cycles: Optional[int]  # None: no kernel run
    pybullet_timing_s: dict[str, float]  # pybullet's own timers of the captured step (empty: not recorded)
    pybullet_iterations: Any
    software_seconds: dict[str, float]  # the numpy solves of this run
    clock_hz: float = 0.0  # the clock this run's latency is quoted at (timing_estimate.clock_note; 0: none)
    clock_why: str = ""


@dataclass
class RunResult:
    """A whole ``make sim`` run (``MODE=rtl``)."""

    name: str  # the run directory's name
    scene: SceneFacts
    schedule: ScheduleFacts
    errors: StepErrors
    thesis: ThesisComparison
    seconds: dict[str, float]  # wall time of each part of the run
    bits: Optional[BitExactness] = None  # None: no kernel run
    speed: Optional[KernelSpeed] = None
    cycle_model: Optional[dict[str, Any]] = None  # sim.compare.retire_cycles.report_section beside the RTL
    window: Optional[WindowFacts] = None
    fit: Optional[FitReport] = None  # sim.fit.resource_model.kernel_fit of the configuration run
    band: Optional[BandReport] = None  # sim.fit.estimate_band.kernel_band: the verdict with the estimate's band
    timing: Optional[TimingReport] = None  # sim.fit.timing_estimate.kernel_timing
    # the cycle model against the RTL run: every retire cycle and the counters (deterministic streams) or its lower
    # bound (random stalls); None: not compared (no kernel run, or a configuration the model does not take)
    model_agrees: Optional[bool] = None

    @property
    def label(self) -> str:
        return self.scene.label

    @property
    def ok(self) -> bool:
        """The kernel agreed with the golden model bit for bit, its counters included (or did not run), and the
        cycle model agreed with the kernel (or was not compared): what make sim's exit status 0 says."""
        return (self.bits is None or self.bits.ok) and self.model_agrees is not False

    def verdict(self) -> dict[str, str]:
        """What decides the exit status, one line per check (the report's first section)."""
        bits = ("not run" if self.bits is None else "agree (0 bits differ, counters equal)" if self.bits.ok
                else f"DIFFER: {self.bits.first_mismatch or f'{self.bits.differing_bits} bits'}")
        model = {None: "not compared", True: "agree", False: "DISAGREE (see the cycle model section)"}
        return {"RTL kernel against the golden model": bits,
                "cycle model against the RTL kernel": model[self.model_agrees],
                "exit status": "0" if self.ok else "1 (a check above failed)"}


@dataclass
class ModelRunResult:
    """``make sim MODE=model``: the cycle model's estimate alone."""

    name: str
    label: str
    bodies: int
    manifolds: int
    schedule: str  # described
    dma: str  # described
    cycle_model: dict[str, Any] = field(default_factory=dict)  # sim.compare.retire_cycles.report_section
    fit: Optional[FitReport] = None  # sim.fit.resource_model.kernel_fit of the configuration predicted
    band: Optional[BandReport] = None  # sim.fit.estimate_band.kernel_band
    timing: Optional[TimingReport] = None  # sim.fit.timing_estimate.kernel_timing
    errors: Union[ExactErrors, NoExactReference, None] = None  # the golden model's step against the exact reference
    error_source: str = ""  # what ``errors.ours`` is of

    @property
    def ok(self) -> bool:
        return True  # nothing compared


AnyRunResult = Union[RunResult, ModelRunResult]


def sections(result: AnyRunResult) -> Sections:
    """The report's sections of a run, in order."""
    if isinstance(result, ModelRunResult):
        model: Sections = {"scene": {"scene": result.label, "bodies": result.bodies, "manifolds": result.manifolds,
                                     "schedule": result.schedule, "DMA preset": result.dma},
                           MODEL_SECTION: result.cycle_model}
        if result.fit is not None:
            model[FIT_SECTION] = fit_section(result.fit, result.band)
        if result.timing is not None:
            model[TIMING_SECTION] = timing_rows(result.timing)
        if result.errors is not None:
            model[ERROR_SECTION] = {**_exact_rows(_exact_labels(result.error_source, "", _name(result.errors)),
                                                  result.errors),
                                    **_reference_rows(result.errors)}
        return model
    s, k = result.scene, result.schedule
    out: Sections = {
        VERDICT_SECTION: result.verdict(),
        "scene": {"scene": s.label, "bodies": s.bodies, "dynamic bodies": s.dynamic_bodies, "manifolds": s.manifolds,
                  "contact points": s.contact_points, "step": s.step, "seed": s.seed},
        "schedule": {"kind": k.kind, "window W (issue slots)": k.window, "slots per pass": k.slots,
                     "bubbles per pass": k.bubbles, "wrap hazards": k.wrap_hazards, "levels per pass": k.levels,
                     "manifold-passes": k.manifold_passes},
    }
    if result.bits is not None:
        out[BITS_SECTION] = _bits(result.bits)
    if result.speed is not None:
        out["kernel speed (RTL in Verilator)"] = _speed(result.speed)
        out["roofline (lower bounds for this configuration)"] = _roofline(result.speed)
    if result.cycle_model is not None:
        out[f"{MODEL_SECTION} vs RTL"] = result.cycle_model
    if result.window is not None:
        out["record window (rtl/pgs_window.sv)"] = _window(result.window)
    if result.fit is not None:
        out[FIT_SECTION] = fit_section(result.fit, result.band)
    if result.timing is not None:
        out[TIMING_SECTION] = timing_rows(result.timing)
    out[ERROR_SECTION] = _errors(result.errors)
    out["comparison with the thesis and with software solvers"] = _thesis(result.thesis)
    out["wall time of this run (s)"] = dict(result.seconds)
    return out


def fit_section(fit: FitReport, band: Optional[BandReport]) -> dict[str, Any]:
    """The resource model's rows, the shares replaced by the banded ones and the verdict by the one with margin."""
    rows = fit_rows(fit)
    if not isinstance(band, BandVerdict):
        return rows
    out: dict[str, Any] = {}
    for key, value in rows.items():
        if key.startswith("LUT, FF, DSP"):
            out["LUT, FF, DSP, BRAM36, URAM (share of the device: Yosys estimate, band, vendor-anchored)"] = \
                band.shares_text()
        elif key.startswith("verdict"):
            out[key.replace("verdict", "verdict at the band's pessimistic end")] = band.headline()
            out["margin per resource (points of the device at the pessimistic end)"] = ", ".join(
                f"{s.resource} {s.margin_points:+.1f}" for k, s in band.shares.items()
                if band.platform.capacity(k) or s.high)
        else:
            out[key] = value
    out["band of the estimate against a vendor flow"] = band_basis()
    gap = band.whole_pipe_gap
    if gap.lut or gap.ff:
        out["Yosys of the whole pipes less their per-operator sums (this configuration's pipes)"] = (
            f"LUT {gap.lut:+,.0f}, FF {gap.ff:+,.0f}")
    return out


def timing_rows(t: TimingReport) -> dict[str, Any]:
    """``timing: meets 275 MHz (estimate)`` or the failing path, the budget, the deepest paths, the distribution."""
    if isinstance(t, NoTiming):
        return {"timing": f"no estimate ({t.reason})"}
    out: dict[str, Any] = {"timing": t.headline(), "budget": t.budget.describe(),
                           "clock the estimate supports": f"{t.clock_hz / 1e6:.0f} MHz"}
    for i, p in enumerate(t.paths[:5], 1):
        over = " (over)" if p.delay_ns > t.required_ns else ""
        out[f"deepest path {i}{over}"] = p.describe()
    for unit, hist in t.histograms.items():
        deepest = next((p for p in t.paths if p.where == unit), None)
        if deepest is not None:
            over = " (over)" if deepest.delay_ns > t.required_ns else ""
            out[f"deepest in {unit}{over}"] = deepest.describe()
        out[f"logic levels of {unit} (register-to-register endpoints)"] = histogram_text(hist)
    if t.argument_paths:
        a = t.argument_paths[0]
        out["from kernel argument registers (static through a step: multicycle, not in the verdict)"] = (
            f"{a.describe()}{' (over one cycle)' if a.delay_ns > t.required_ns else ''}")
    if t.missing:
        out["not covered"] = "; ".join(t.missing)
    if t.notes:
        out["assumptions on these paths"] = "; ".join(t.notes)
    return out


def _bits(b: BitExactness) -> dict[str, Any]:
    return {"bits differing from the golden model (must be 0)": b.differing_bits, "words differing": b.differing_words,
            "trace records compared": b.records, "body-out records compared": b.bodies,
            "first mismatch": b.first_mismatch or "none", "random stall seed": b.stall_seed}


def _speed(v: KernelSpeed) -> dict[str, Any]:
    return {
        "driver": v.driver, "format": v.fmt, "DMA preset": v.dma,
        "kernel cycles (ap_start to ap_done)": v.cycles, "cycles per manifold-pass": v.cycles / v.manifold_passes,
        "stall cycles (hazard and stream waits)": v.stalls, "bubble cycles (no record to issue)": v.bubbles,
        "schedule bubbles per pass": v.schedule_bubbles,
        **{f"latency at {f / 1e6:g} MHz (ms)": v.cycles / f * 1e3 for f in baselines.REPORT_CLOCKS_HZ},
        "bytes streamed in (bodies + constraints)": v.bytes_in, "bytes streamed out (bodies)": v.bytes_out,
        "constraint bytes per manifold per step": v.cons_bytes_per_manifold,
        "DDR bandwidth utilisation": "uncapped" if v.ddr_utilisation is None else v.ddr_utilisation,
        "co-simulation speed (simulated cycles per wall second)": v.sim_cycles_per_s,
        "kernel run wall time (s)": v.wall_s, "Verilator build time this run (s)": v.build_s,
        **({} if v.cpu_s is None else {"kernel run CPU time (s)": v.cpu_s}),
    }


def _roofline(v: KernelSpeed) -> dict[str, Any]:
    out: dict[str, Any] = {f"{k} floor (cycles)": f for k, f in v.floors.items()}
    out["measured cycles"] = v.cycles
    out["bound by"] = v.bound
    out["measured / highest floor"] = v.cycles / max(v.floors[v.bound], 1.0)
    return out


def _window(w: WindowFacts) -> dict[str, Any]:
    p = w.plan
    out: dict[str, Any] = {
        "ring (records, build parameter WINDOW)": p.depth, "pass contexts (WINDOW_CTX)": p.ctx,
        "issue lanes (LANES)": p.lanes, "empty lanes (padding)": p.empty_lanes,
        "band width D of the record order": p.band, "lag (records a pass trails the one before)": p.lag,
        "passes per fetch": p.fetch_passes, "fetches of the records per step": w.fetches,
        "ring records in use at most": p.ring_records,
        "cycle model": "models/timing/window_cycle_model.py (the cycle model section)"}
    b = w.budget
    if b is not None:
        out[f"on-chip bytes on {b.platform.name}: body state + impulses + window"] = (
            f"{b.body_bytes:,} + {b.impulse_bytes:,} + {b.window_bytes:,} = {b.total_bytes:,} of "
            f"{b.platform.data_bytes:,} data bytes ({'within' if b.fits else 'beyond'} them, counted as bytes; "
            f"blocks with their port copies: {FIT_SECTION})")
    return out


def _velocity_rows(label: str, e: VelocityError) -> dict[str, float]:
    return {f"{label}: max |dv| (m/s)": e.max_dv, f"{label}: max |dw| (rad/s)": e.max_dw,
            f"{label}: max |dv| / max |v|": e.relative}


def _solution_rows(label: str, e: SolutionError) -> dict[str, float]:
    return {f"{label}: max |dv| (m/s)": e.max_dv, f"{label}: median |dv| (m/s)": e.median_dv,
            f"{label}: p99 |dv| (m/s)": e.p99_dv, f"{label}: max |dv| / max |v_ref|": e.relative_dv,
            f"{label}: max |dw| (rad/s)": e.max_dw, f"{label}: median |dw| (rad/s)": e.median_dw,
            f"{label}: p99 |dw| (rad/s)": e.p99_dw, f"{label}: max |dw| / max |w_ref|": e.relative_dw}


def _exact_rows(labels: tuple[str, ...], x: Union[ExactErrors, NoExactReference]) -> dict[str, Any]:
    """The three errors against the exact reference (or, without one, why not) under ``labels``."""
    if isinstance(x, NoExactReference):
        return {label: str(x) for label in labels}
    out: dict[str, Any] = {}
    for label, err in zip(labels, (x.ours, x.iteration_only, x.converged)):
        if err is not None:
            out.update(_solution_rows(label, err))
    return out


def _exact_labels(source: str, pgs: str, reference: str = "exact reference") -> tuple[str, ...]:
    """The rows' labels: ``source``, float64 with the same iterations, and (unless ``pgs`` is empty) the PGS iterate,
    each against ``reference`` (what the reference is: ``ExactReferenceFacts.name``)."""
    return (f"{source} vs {reference} (rounding + iteration error)",
            f"float64 with these iterations vs {reference} (iteration error alone)") + (
        (f"{pgs} vs {reference}",) if pgs else ())


def _name(x: Union[ExactErrors, NoExactReference]) -> str:
    return x.reference.name if isinstance(x, ExactErrors) else "exact reference"


def _reference_rows(x: Union[ExactErrors, NoExactReference]) -> dict[str, Any]:
    """The exact reference's solver, islands, solve times, natural residuals, contact-phase bound, cache file."""
    if isinstance(x, NoExactReference):
        return {"exact reference": str(x)}
    r = x.reference
    out: dict[str, Any] = {"exact reference: solver": r.solver, "exact reference: islands": r.islands}
    out.update({f"exact reference: {k} solve time (s)": v for k, v in r.seconds.items()})
    out.update({f"exact reference: {k}": v for k, v in r.details.items()})
    out.update({f"exact reference residual, {k}": v for k, v in r.residuals.items()})
    out.update({f"exact reference, contact phase, {k}": v for k, v in r.contact_bound.items()})
    out["exact reference: cache file"] = r.cache_file + (" (read from the cache)" if r.from_cache else "")
    return out


def _projection(passes: float) -> str:
    if passes == 0:
        return "converged"
    if math.isnan(passes):
        return f"unknown (stopped within {RATE_WINDOW} passes)"
    return "no progress" if math.isinf(passes) else f"{passes:.2g}"


def _errors(e: StepErrors) -> dict[str, Any]:
    pgs = f"float64 PGS after {e.converged_passes[0]} contact and {e.converged_passes[1]} friction passes"
    out: dict[str, Any] = {}
    out.update(_velocity_rows(f"{e.source} vs float64, same schedule and iterations (rounding error)",
                              e.vs_same_iterations))
    out.update(_exact_rows(_exact_labels(e.source, pgs, _name(e.vs_exact)), e.vs_exact))
    out.update(_velocity_rows(f"{e.source} vs {pgs}", e.vs_converged))
    out[f"{pgs}: last pass max velocity change"] = e.converged_last_change
    out[f"{pgs}: per-pass change below 1e-9 within budget"] = str(e.converged)
    if not e.converged:
        out[f"{pgs}: passes still needed at the last {RATE_WINDOW} passes' rate (contact, friction)"] = ", ".join(
            _projection(p) for p in e.converged_projected)
    out.update(_reference_rows(e.vs_exact))
    out.update({f"residual after the {e.source}'s solve: {k}": v for k, v in e.residual_after_solve.items()})
    out.update({f"residual after the converged solve ({pgs}): {k}": v for k, v in e.residual_converged.items()})
    if e.thesis_within_1pct is not None:
        out["thesis statistic: share of position values within 1% of the fp32 result"] = e.thesis_within_1pct
        out["thesis statistic: average relative position difference from fp32"] = e.thesis_mean_relative
    out.update(_velocity_rows(f"{e.source} vs pybullet's own step (a different solver: Bullet 2 sequential impulse)",
                              e.vs_pybullet))
    return out


def _thesis(t: ThesisComparison) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for fig in baselines.THESIS_FPGA.values():
        out[f"{fig.label} ({baselines.THESIS_MANIFOLDS:,} manifolds, {fig.clock_hz / 1e6:g} MHz)"] = (
            f"{fig.cycles:,} cycles, {fig.ms} ms, {fig.cycles_per_manifold_pass:.2f} cycles/manifold-pass")
    out["thesis GTX 980 (Bullet3 OpenCL)"] = f"{baselines.THESIS_GPU_MS} ms"
    out["thesis i7-3770 (Bullet3)"] = f"{baselines.THESIS_CPU_MS} ms"
    if t.rtl_cycles is not None:
        cpmp = t.rtl_cycles / t.manifold_passes
        hz = t.clock_hz or 275e6  # the clock the timing estimate supports (none given: the platform's 275 MHz)
        mhz = f"{hz / 1e6:.0f} MHz"
        if t.clock_why:
            out["clock of this run's latency"] = t.clock_why
        same = baselines.THESIS_FPGA.get(t.fmt)  # the thesis's design of this format, at its own clock
        at_thesis_clock = "" if same is None or same.clock_hz == hz else (
            f" ({t.rtl_cycles / same.clock_hz * 1e3:.2f} ms at the thesis {t.fmt} design's {same.clock_hz / 1e6:g} MHz)")
        out[f"this run: RTL {t.fmt}, {t.manifolds:,} manifolds, {t.iterations} iterations"] = (
            f"{t.rtl_cycles:,} cycles, {t.rtl_cycles / hz * 1e3:.2f} ms at {mhz}{at_thesis_clock}, "
            f"{cpmp:.2f} cycles/manifold-pass")
        scaled = cpmp * baselines.THESIS_MANIFOLDS * 2 * t.iterations
        out[f"this run scaled to {baselines.THESIS_MANIFOLDS:,} manifolds"] = (
            f"{scaled:,.0f} cycles, {scaled / hz * 1e3:.2f} ms at {mhz}")
    timing = t.pybullet_timing_s
    if timing:
        out[f"pybullet's own solver on this frame (this machine, {t.pybullet_iterations} iterations, solveGroup)"] = (
            f"{timing.get('solveGroup', math.nan) * 1e3:.2f} ms (whole step "
            f"{timing.get('internalSingleStepSimulation', math.nan) * 1e3:.2f} ms)")
    else:
        out["pybullet's own solver on this frame"] = "not recorded (frame cached before timings were kept)"
    for name, sec in t.software_seconds.items():
        out[f"{name} (this machine)"] = f"{sec * 1e3:.1f} ms"
    return out
