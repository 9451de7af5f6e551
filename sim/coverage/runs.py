"""Running the coverage cases (``sim.coverage.cases``): inputs prepared (and edited), the instrumented harness or
test run, its ``coverage.dat`` kept; a failing run is reported in its :class:`CaseResult`, the rest go on."""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

from models import scenes
from models.golden.contact_solver import SolverParams
from models.timing.platforms import get_preset
from sim.drive.cocotb_run import BUILD_ROOT as COCOTB_BUILD_ROOT
from sim.coverage.build import (COVERAGE_ARGS, COVERAGE_COMPILE_PROFILE, build_coverage_fp_ops, build_coverage_kernel,
                                coverage_kernel_build)
from sim.coverage.cases import CASES, FP_OPERATOR_CASES, REGISTER_CASE, SCENES, Case, SharedCase, case_dir
from sim.coverage.configurations import BY_NAME, CONFIGURATIONS, Configuration
from sim.coverage.input_edits import HarnessFiles
from sim.drive.fp_operator_harness import run_fp_operator_harness
from sim.drive.fp_operator_vectors import make_vectors, seed_for
from sim.drive.harness_run import TIMEOUT_PER_ITEM, KernelRunError, harness_cycle_limit, run_harness, write_inputs
from sim.compile.verilator_build import QUICK_COMPILE_ARGS, REPO_ROOT


@dataclass
class CaseResult:
    case: Case | SharedCase
    coverage: Path | None  # coverage.dat (None: the run failed)
    seconds: float
    registers: dict[str, float] = field(default_factory=dict)
    error: str = ""

    @property
    def status_line(self) -> str:
        return f"  {self.case.label}: {self.seconds:.1f} s {self.error or 'ok'}"

    @property
    def shared(self) -> bool:
        """A run outside the kernel harness (its coverage counts for several configurations)."""
        return isinstance(self.case, SharedCase)

    def counts_for(self, config: Configuration) -> bool:
        """Whether this run's coverage is part of ``config``'s."""
        return self.case.config == config.name if isinstance(self.case, Case) else self.case.counts_for(config)


@dataclass(frozen=True)
class PreparedRun:
    """What the harness run of a prepared case needs beside its input files."""

    max_cycles: int  # the harness's cycle limit
    read_share: float  # the share of the DDR bandwidth the constraint reads get (impulses in the records: < 1)


def prepare_case(case: Case, run_dir: Path) -> PreparedRun:
    """Write the case's harness inputs into ``run_dir`` (edited for bad input); return its cycle limit and DDR
    read share."""
    scene, params = SCENES[case.scene]
    config = case.configuration
    kb = config.build()
    preset = get_preset(case.dma)
    if preset.stream_bits != kb.cons_bits:
        raise ValueError(f"{case.label}: DMA model {case.dma} has {preset.stream_bits}-bit beats, the build "
                         f"{kb.cons_bits}")
    job = config.job(scenes.load_or_capture(scene, **params), SolverParams(4, interleaved=case.interleaved),
                     case.schedule, case.fetch_passes)
    if case.job_edit is not None:
        job = case.job_edit(job)
    if job.friction_words != kb.friction_words:
        raise ValueError(f"{case.label}: the step has {job.friction_words} friction-coefficient words per record, "
                         f"the build {kb.friction_words}")
    write_inputs(run_dir, job, kb, preset.impulse_turnaround_cycles)
    extra_bodies = 0  # bodies an edit adds to the step (the cycle limit grows with them)
    if case.edit is not None:
        files = HarnessFiles(run_dir, kb)
        case.edit(files, kb)
        files.save()
        extra_bodies = max(0, files.reg("num_bodies") - job.bodies.num_bodies)
    return PreparedRun(harness_cycle_limit(job) + TIMEOUT_PER_ITEM * extra_bodies,
                       job.ddr_read_share(kb.cons_bits))


def run_case(case: Case, exe: Path, run_dir: Path, seed: int = 1) -> CaseResult:
    """Prepare the case's inputs, run the coverage harness, keep its coverage.dat."""
    t0 = time.monotonic()
    prepared = prepare_case(case, run_dir)
    cov = run_dir / "coverage.dat"
    cov.unlink(missing_ok=True)
    try:
        regs = run_harness(exe, run_dir, seed, get_preset(case.dma), prepared.max_cycles, case.stalls, case.stalls,
                           env=dict(os.environ, PGS_COVERAGE_FILE=str(cov)), read_share=prepared.read_share)
    except KernelRunError as exc:
        return CaseResult(case, None, time.monotonic() - t0, error=str(exc))
    return CaseResult(case, cov if cov.exists() else None, time.monotonic() - t0, regs,
                      "" if cov.exists() else "no coverage.dat written")


def register_coverage_file() -> Path:
    """Where the register test's coverage build (``sim.drive.cocotb_run``) leaves coverage.dat."""
    return COCOTB_BUILD_ROOT / "pgs_control_s_axi_coverage" / "coverage.dat"


def run_register_test() -> CaseResult:
    """The register file's own cocotb test (``cocotb_tests/test_pgs_control_s_axi.py``) on a coverage build of
    ``pgs_control_s_axi`` (``build/cocotb/pgs_control_s_axi_coverage/``): the register paths the harness never
    takes (reads of every register, byte strobes, auto_restart, the ap_ready interrupt). cocotb's Verilator main
    writes ``coverage.dat`` into the build directory when the simulation ends."""
    from sim.drive.cocotb_run import TESTS_DIR, run_cocotb

    t0 = time.monotonic()
    cov = register_coverage_file()
    cov.unlink(missing_ok=True)
    # cocotb's runner hands the simulator this process's sys.path as PYTHONPATH: the test module must be on it
    added = [p for p in (str(REPO_ROOT), str(TESTS_DIR)) if p not in sys.path]
    sys.path.extend(added)
    try:
        results = run_cocotb("pgs_control_s_axi", [REPO_ROOT / "rtl" / "generated" / "pgs_regs_pkg.sv",
                                                   REPO_ROOT / "rtl" / "pgs_control_s_axi.sv"],
                             "test_pgs_control_s_axi", name=cov.parent.name,
                             compile_args=[*COVERAGE_ARGS, *QUICK_COMPILE_ARGS])
        ran = results.is_file() and "<testcase" in results.read_text()
    except Exception as exc:  # a failing cocotb test or build: reported, the rest of the summary stands
        return CaseResult(REGISTER_CASE, None, time.monotonic() - t0, error=f"{type(exc).__name__}: {exc}")
    finally:
        for p in added:
            sys.path.remove(p)
    error = "" if ran and cov.exists() else ("no cocotb test ran" if not ran else "no coverage.dat written")
    return CaseResult(REGISTER_CASE, cov if not error else None, time.monotonic() - t0, error=error)


def run_fp_operator_case(case: SharedCase, out: Path) -> CaseResult:
    """The fp-operator vectors (``sim.drive.fp_operator_vectors``) through a coverage build of their harness."""
    t0 = time.monotonic()
    assert case.fmt is not None
    run_dir = case_dir(out, case.label)
    run_dir.mkdir(parents=True, exist_ok=True)
    cov = run_dir / "coverage.dat"
    cov.unlink(missing_ok=True)
    try:
        exe = build_coverage_fp_ops(case.fmt, out)
        seed = seed_for(case.fmt.name)
        vec, _ = make_vectors(case.fmt.name, seed)
        _, proc = run_fp_operator_harness(exe, vec, run_dir, seed, env=dict(os.environ, PGS_COVERAGE_FILE=str(cov)))
        (run_dir / "in.bin").unlink()
        (run_dir / "out.bin").unlink(missing_ok=True)
    except Exception as exc:  # a failing build: reported, the rest of the summary stands
        return CaseResult(case, None, time.monotonic() - t0, error=f"{type(exc).__name__}: {exc}")
    error = f"harness exit {proc.returncode}: {proc.stderr[-500:]}" if proc.returncode else \
        ("" if cov.exists() else "no coverage.dat written")
    return CaseResult(case, cov if cov.exists() and not proc.returncode else None, time.monotonic() - t0,
                      error=error)


def previous_results(out: Path, configs: Sequence[str] = ()) -> list[CaseResult]:
    """The coverage files of the runs in ``out`` (and of the register test) from an earlier ``make coverage``: of
    the configurations ``configs`` (all when empty) and the shared runs that count for them."""
    wanted = [BY_NAME[n] for n in configs] or list(CONFIGURATIONS)
    cases = [c for c in CASES if c.configuration in wanted]
    shared = [c for c in FP_OPERATOR_CASES if any(c.counts_for(w) for w in wanted)]
    runs = [CaseResult(c, case_dir(out, c.label) / "coverage.dat", 0.0) for c in [*cases, *shared]]
    runs.append(CaseResult(REGISTER_CASE, register_coverage_file(), 0.0))
    return [r if r.coverage and r.coverage.exists() else CaseResult(r.case, None, 0.0, error="no coverage.dat")
            for r in runs]


def build_configurations(configs: Sequence[Configuration], out: Path,
                         profile: str = COVERAGE_COMPILE_PROFILE) -> dict[str, Path]:
    """The instrumented harness of each configuration, compiled with ``profile`` (built once; Verilator skips an
    unchanged build)."""
    exes = {}
    for config in configs:
        t0 = time.monotonic()
        exes[config.name] = build_coverage_kernel(config.build(), out, profile)
        print(f"coverage build {config.name} ({coverage_kernel_build(config.build(), profile).name}): "
              f"{time.monotonic() - t0:.0f} s", flush=True)
    return exes


def run_all(out: Path, jobs: int, labels: Sequence[str] = (), configs: Sequence[str] = (),
            profile: str = COVERAGE_COMPILE_PROFILE) -> list[CaseResult]:
    """Build what the cases named by ``labels`` of the configurations ``configs`` (all when empty) need (compiled
    with ``profile``), run them (``jobs`` at a time); with all cases, then the fp-operator vectors and the register
    test."""
    wanted = [c for c in CASES if (not labels or c.label in labels) and (not configs or c.config in configs)]
    exes = build_configurations([cfg for cfg in CONFIGURATIONS if any(c.config == cfg.name for c in wanted)], out,
                                profile)

    def one(case: Case) -> CaseResult:
        res = run_case(case, exes[case.config], case_dir(out, case.label))
        print(res.status_line, flush=True)
        return res

    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        results = list(pool.map(one, wanted))
    if not labels:
        fmts = {BY_NAME[c].fmt for c in configs} if configs else None
        shared = [c for c in FP_OPERATOR_CASES if fmts is None or c.fmt in fmts]
        for run in [*(lambda c=c: run_fp_operator_case(c, out) for c in shared), run_register_test]:
            results.append(run())
            print(results[-1].status_line, flush=True)
    return results
