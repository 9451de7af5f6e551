"""`make sim` on a tiny scene: the run finishes and the report carries the expected fields; bad input to
`python -m sim.run` and `python -m sim.sweep` ends them with one error line, exit status 2 and no output
left behind."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pytest

from models import scenes
from models.formats.frame import load, save
from models.formats.number_format import FLOAT64, FP32
from models.golden.contact_solver import SolverParams, solve
from models.golden.integrator import IntegrationParams, integrate
from models.kernel.kernel_job import KernelJob
from models.order.manifold_schedule import make_schedule
from models.setup.constraints import body_table, setup_constraints
from models.timing.platforms import get_preset
from sim.compile.kernel_build import default_window
from sim.drive.kernel_step import golden_step
from sim import run as sim_run
from sim.report import pareto_front
from sim.report.run_result import FIT_SECTION, TIMING_SECTION
from sim import sweep as sim_sweep
from sim.report import sweep_plot
from sim.drive.harness_run import KernelRunError

REPO = Path(__file__).resolve().parents[2]


def test_sim_run_reports(tmp_path: Path) -> None:
    """`make sim` on the stack: the RTL kernel runs (the build is shared with test_pgs_kernel), 0 differing bits,
    and the report carries every section docs/architecture.md ("The report") describes."""
    out = tmp_path / "sim"
    cmd = [sys.executable, "-m", "sim.run", "--scene", "stack", "--iters", "2", "--format", "fp32",
           "--out", str(out), "--converged-budget", "20"]
    proc = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=1200)
    print(proc.stdout[-4000:])
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    report = json.loads(next(out.glob("*/report.json")).read_text())
    assert report["scene"]["manifolds"] > 0 and report["scene"]["contact points"] >= report["scene"]["manifolds"]
    assert report["schedule"]["manifold-passes"] == 4 * report["scene"]["manifolds"]
    bits = report["bit-exactness (RTL kernel against the golden model, same format)"]
    assert bits["bits differing from the golden model (must be 0)"] == 0 and bits["first mismatch"] == "none"
    assert bits["trace records compared"] == report["schedule"]["manifold-passes"]
    speed = report["kernel speed (RTL in Verilator)"]
    assert speed["kernel cycles (ap_start to ap_done)"] >= report["schedule"]["manifold-passes"]
    assert speed["co-simulation speed (simulated cycles per wall second)"] > 0
    roof = report["roofline (lower bounds for this configuration)"]
    assert roof["measured cycles"] >= max(v for k, v in roof.items() if k.endswith("floor (cycles)"))
    verdict = report["verdict (what decides the exit status)"]
    assert verdict == {"RTL kernel against the golden model": "agree (0 bits differ, counters equal)",
                       "cycle model against the RTL kernel": "agree", "exit status": "0"}
    # the errors, recomputed here: the kernel's step (= the golden model's, bit for bit) against float64 with the
    # same schedule and iterations; against the exact reference within that rounding error of float64's own error
    err = report["error (velocities after the step; dynamic bodies)"]
    frame, _ = scenes.load_scene("stack", "", 1)
    bodies, cons = body_table(frame), setup_constraints(frame, body_table(frame))
    schedule = make_schedule("hazard", cons, bodies.dynamic, default_window(FP32, get_preset("zcu102").stream_bits))
    ip = IntegrationParams(dt=frame.dt, gravity=tuple(frame.gravity))
    ours = golden_step(KernelJob(FP32, bodies.rounded(FP32), cons.rounded(FP32), schedule, SolverParams(2), ip)).final
    ref = integrate(solve(bodies, cons, schedule, FLOAT64, SolverParams(2)).bodies, FLOAT64, ip)
    dv = ours.linear_velocity[bodies.dynamic] - ref.linear_velocity[bodies.dynamic]
    label = "RTL kernel vs float64, same schedule and iterations (rounding error)"
    assert err[f"{label}: max |dv| (m/s)"] == np.abs(dv).max()  # the largest component, exactly
    assert 0 < np.abs(dv).max() < 1e-5  # fp32 against float64 after 2 iterations on the 10-cube stack
    # the exact reference's errors are per-body norms: the two differ by at most the largest rounding norm
    exact = err["RTL kernel vs exact reference (rounding + iteration error): max |dv| (m/s)"]
    iteration = err["float64 with these iterations vs exact reference (iteration error alone): max |dv| (m/s)"]
    rounding = np.linalg.norm(dv, axis=1).max()
    assert iteration > 0.01 and abs(exact - iteration) <= rounding * (1 + 1e-9)  # 2 iterations are far from the limit
    residuals = [v for k, v in err.items() if k.startswith("residual after the RTL kernel's solve")]
    assert residuals and all(np.isfinite(v) and v >= 0 for v in residuals)
    assert "thesis ZCU102 fp32 (127,000 manifolds, 275 MHz)" in report["comparison with the thesis and with software solvers"]
    # the fit verdict at the band's pessimistic end, with its margin, and the timing estimate against 275 MHz
    fit = report[FIT_SECTION]
    verdict = next(v for k, v in fit.items() if k.startswith("verdict at the band's pessimistic end"))
    assert verdict.startswith("FITS the zcu102: ") and "points to spare at the pessimistic end" in verdict
    assert "(band " in fit["LUT, FF, DSP, BRAM36, URAM (share of the device: Yosys estimate, band, vendor-anchored)"]
    timing = report[TIMING_SECTION]["timing"]
    assert timing.startswith(("meets 275 MHz (estimate)", "fails 275 MHz (estimate)")), timing
    assert report[TIMING_SECTION]["clock the estimate supports"].endswith(" MHz")
    assert (next(out.glob("*/report.md"))).read_text().startswith("# pgs-cosim run")
    assert [p.name for p in out.iterdir()] == [next(out.glob("*/report.json")).parent.name]  # nothing staged left


def test_sim_run_rejects_bad_input(tmp_path: Path) -> None:
    for args, word in ((["--format", "fp33"], "number format"), (["--dma", "nope"], "DMA preset"),
                       (["--scene", "nope"], "unknown scene")):
        proc = subprocess.run([sys.executable, "-m", "sim.run", "--out", str(tmp_path), *args], cwd=REPO,
                              capture_output=True, text=True, timeout=120)
        assert proc.returncode != 0
        # pybullet's C module prints a build banner on import; everything else is one error line
        lines = [ln for ln in proc.stderr.splitlines() if not ln.startswith("pybullet build time")]
        assert len(lines) == 1 and lines[0].startswith("error:") and word in lines[0], proc.stderr
        assert not any(tmp_path.iterdir())


# --- bad input, in process (the same main() as the command line; one subprocess case above) -------------------
def _frame_file(tmp: Path, damage: Callable[[Path], None] | None = None) -> Path:
    """The 2-cube stack's frame saved to a file, then damaged."""
    path = save(scenes.load_or_capture("stack", n=2), tmp / "frames" / "stack2.npz")
    if damage is not None:
        damage(path)
    return path


def _older_version(path: Path) -> None:
    with np.load(path, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    meta = json.loads(str(arrays["meta_json"]))
    arrays["meta_json"] = np.array(json.dumps(dict(meta, frame_version=0)))
    np.savez(path, **arrays)


FRAME_DAMAGE: dict[str, tuple[Callable[[Path], None], str]] = {
    "corrupt": (lambda p: p.write_bytes(b"\x00garbage" * 64), "is corrupt"),
    "truncated": (lambda p: p.write_bytes(p.read_bytes()[:300]), "is corrupt or truncated"),
    "older version": (_older_version, "has version 0, this tool reads version"),
}
RUN_CASES = [
    (["--format", "float64"], "not a kernel format"),
    (["--format", "e11m52"], "exponent width 11"),
    (["--iters", "0"], "ITERS must be >= 1"),
    (["--schedule", "random"], "unknown schedule"),
    (["--stall-permille", "1500"], "--stall-permille must be in 0..1000"),
    (["--converged-budget", "nan"], "--converged-budget must be >= 0"),
    (["--exact-budget", "nan"], "--exact-budget must be >= 0"),
    (["--seed", "-1"], "seed must be a non-negative integer"),
    (["--window", "-3"], "--window must be >= 0"),
    (["--lanes", "2"], "above 1 only with --record-window"),
    (["--record-window", "1024", "--lanes", "3"], "--lanes must be a power of two"),
    (["--body-bits", "64"], "--body-bits must be 128, 256 or 512"),
    (["--record-window", "1024", "--tangents", "chip"], "TANGENTS=chip is a configuration of the streaming kernel"),
    (["--dma", "zcu999"], "unknown DMA preset 'zcu999'"),
    (["--frame", "/nonexistent/frame.npz"], "does not exist"),
    (["--driver", "cocotb", "--compile-profile", "pgo"], "COMPILE= is the compiled harness's"),
    (["--datapath", "xls", "--format", "bf16"], "DATAPATH=xls does not cover FORMAT=bf16"),
    (["--datapath", "xls", "--tangents", "chip"], "DATAPATH=xls does not cover TANGENTS=chip"),
    (["--datapath", "xls", "--add-dsp", "1"], "DATAPATH=xls does not cover ADD_DSP=1"),
]
SWEEP_CASES = [
    (["--formats", "fp32,fp33"], "unknown number format 'fp33'"),
    (["--formats", "bf16,float64"], "not a kernel format"),
    (["--iters", "1,0"], "ITERS must be positive integers"),
    (["--iters", "2,x"], "ITERS must be comma-separated integers"),
    (["--dma", "u999"], "unknown DMA preset 'u999'"),
    (["--scene", "stack", "--seed", "-4"], "seed must be a non-negative integer"),
    (["--scene", "teapot"], "unknown scene 'teapot'"),
    (["--exact-budget", "-1"], "--exact-budget must be >= 0"),
    (["--record-window", "1000"], "--record-window must be 0 or a power of two"),
    (["--fetch-passes", "9"], "--fetch-passes must be in 0..8"),
    (["--impulse-stores", "onchip,flash"], "IMPULSE_STORES must be a comma-separated list"),
    (["--record-window", "64", "--impulse-stores", "records", "--fetch-passes", "3", "--iters", "2"], "one kind"),
]
TOOLS: dict[str, Callable[[list[str]], int]] = {"sim.run": sim_run.main, "sim.sweep": sim_sweep.main}


def _expect_error(tool: str, argv: list[str], out: Path, words: str, capsys: pytest.CaptureFixture[str]) -> None:
    rc = TOOLS[tool]([*argv, "--out", str(out)])
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip() and not ln.startswith("pybullet build")]
    assert rc == 2, f"{tool} {argv}: exit status {rc}"
    assert len(err) == 1 and err[0].startswith("error: ") and words in err[0], f"{tool} {argv}: {err}"
    assert not out.exists(), f"{tool} {argv} left {sorted(p.name for p in out.rglob('*'))}"


BAD_ARGUMENTS = [("sim.run", ["--scene", "stack", "--no-kernel", *argv], words) for argv, words in RUN_CASES] + [
    ("sim.sweep", argv, words) for argv, words in SWEEP_CASES]


@pytest.mark.parametrize("tool,argv,words", BAD_ARGUMENTS, ids=[f"{t} {' '.join(a[-2:])}" for t, a, _ in BAD_ARGUMENTS])
def test_tools_reject_bad_arguments(tmp_path: Path, capsys: pytest.CaptureFixture[str], tool: str, argv: list[str],
                                    words: str) -> None:
    _expect_error(tool, argv, tmp_path / "out", words, capsys)


@pytest.mark.parametrize("tool", list(TOOLS))
@pytest.mark.parametrize("damage", list(FRAME_DAMAGE))
def test_tools_reject_bad_frame_files(tmp_path: Path, capsys: pytest.CaptureFixture[str], tool: str,
                                      damage: str) -> None:
    """A corrupt, truncated or older-version frame file given with --frame: one line naming the file and the
    problem, exit status 2, no output directory; the frame file itself is left as it was."""
    fn, words = FRAME_DAMAGE[damage]
    path = _frame_file(tmp_path, fn)
    before = path.read_bytes()
    extra = ["--no-kernel"] if tool == "sim.run" else ["--iters", "1"]
    _expect_error(tool, ["--frame", str(path), *extra], tmp_path / "out", f"frame file {path} {words}", capsys)
    assert path.read_bytes() == before


def test_body_beats_the_cycle_model_cannot_take_are_refused_before_the_build(tmp_path: Path,
                                                                          capsys: pytest.CaptureFixture[str]) -> None:
    """The streaming kernel on 512-bit body beats, more than the zcu102's DDR gives a cycle: one line, exit status
    2, no run directory, before any build (in RTL mode and in MODE=model)."""
    for mode in ("rtl", "model"):
        _expect_error("sim.run", ["--scene", "stack", "--body-bits", "512", "--mode", mode], tmp_path / mode,
                      "less than one 512-bit body beat per cycle: not modeled", capsys)


def test_failed_runs_leave_no_partial_output(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                             monkeypatch: pytest.MonkeyPatch) -> None:
    """The kernel step fails after writing its input files into the run (sweep) directory: the error is one
    line, the exit status 2, and no directory is left -- neither a new one nor a half-written one over an older
    complete run, which stays as it was."""
    def failing_step(job: Any, preset: Any, run_dir: Path, *args: Any, **kw: Any) -> Any:
        run_dir.mkdir(parents=True, exist_ok=True)
        (run_dir / "regs.bin").write_bytes(b"\0" * 16)
        raise KernelRunError("kernel harness failed (exit 3): TIMEOUT after 1000 cycles")

    monkeypatch.setattr(sim_run, "run_kernel_step", failing_step)
    monkeypatch.setattr(sim_sweep, "run_kernel_step", failing_step)
    frame = _frame_file(tmp_path)
    out = tmp_path / "out"
    argv = ["--frame", str(frame), "--iters", "1", "--out", str(out)]
    run_only = ["--converged-budget", "1"]
    assert sim_run.main([*argv, *run_only, "--no-kernel"]) == 0  # an older, complete run of the same name
    (run_dir,) = out.iterdir()
    old = {p.name: p.read_bytes() for p in run_dir.iterdir()}
    capsys.readouterr()
    for tool, extra in (("sim.run", run_only), ("sim.sweep", ["--formats", "fp16"])):
        assert TOOLS[tool]([*argv, *extra]) == 2
        err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
        assert err == ["error: kernel harness failed (exit 3): TIMEOUT after 1000 cycles"], (tool, err)
        assert [p.name for p in out.iterdir()] == [run_dir.name], (tool, sorted(p.name for p in out.rglob("*")))
        assert {p.name: p.read_bytes() for p in run_dir.iterdir()} == old


def test_sim_run_frame_file(tmp_path: Path) -> None:
    """--frame runs a saved frame: the run directory is named after the file and reports its bodies."""
    frame = _frame_file(tmp_path)
    out = tmp_path / "out"
    assert sim_run.main(["--frame", str(frame), "--no-kernel", "--iters", "1", "--converged-budget", "1",
                         "--out", str(out)]) == 0
    (run_dir,) = out.iterdir()
    assert run_dir.name == "stack2-fp32-it1-s1-zcu102"
    report = json.loads((run_dir / "report.json").read_text())
    assert report["scene"]["scene"] == "stack2" and report["scene"]["bodies"] == load(frame).num_bodies


def test_sweep_columns_and_plot_without_an_exact_reference(tmp_path: Path) -> None:
    """make sweep's error columns against the exact reference, and its csv and plot when there is none: every such
    column says why, and the plot is still written."""
    from models.exact.solution_error import SolutionError
    from sim.compare.exact_error import NoExactReference

    base: dict[str, Any] = {col: 1.0 for col in sim_sweep.COLUMNS}
    base.update(format="fp32", iterations=1, differing_bits=0)
    measured = sim_sweep.exact_columns(SolutionError(1e-2, 1e-3, 5e-3, 2e-2, 3e-3, 4e-3, 0.1, 0.2))
    assert measured["max_dv_vs_exact"] == 1e-2 and measured["p99_dw_vs_exact"] == 4e-3
    missing = sim_sweep.exact_columns(NoExactReference("QP solver hit the time budget"))
    exact_cols = [c for c in sim_sweep.COLUMNS if c.endswith("_vs_exact")]
    assert sorted(measured) == sorted(missing) == sorted(exact_cols)
    assert set(missing.values()) == {"no exact reference (QP solver hit the time budget)"}
    for rows in ([dict(base, **measured), dict(base, **missing)], [dict(base, **missing)]):
        sim_sweep.write_csv(rows, tmp_path / "sweep.csv")
        sweep_plot.plot(rows, tmp_path / "sweep.png", "pile-zcu102")
        assert (tmp_path / "sweep.png").stat().st_size > 0
        (tmp_path / "sweep.png").unlink()
        pareto_front.plot(rows, tmp_path / "pareto.png", "pile-zcu102")  # the front of the rows that have errors
        assert (tmp_path / "pareto.png").stat().st_size > 0
    assert "no exact reference, no front" in pareto_front.report([dict(base, **missing)])
    assert "no exact reference (QP solver hit the time budget)" in (tmp_path / "sweep.csv").read_text()
