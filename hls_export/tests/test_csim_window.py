"""C simulation of the HLS kernel's window design (PGS_WINDOW > 0 with PGS_IMPULSES_IN_RECORDS=1, the RTL's window
kernel with the impulses in the records): each fetch of the records serves passes of one kind over an on-chip ring of
window records of PGS_LANES slots, the fetch's passes trailing each other by ``lag`` records, an impulse ring carrying
each slot's impulses from pass to pass, the fetch's last pass writing them to m_axis_imp (one record per window
record), which the testbench's DMA writes to the impulse buffer the next fetch's records are read with.

Against the golden model bit for bit in the trace (sorted into the sequential order), the body-out stream and the
impulse-out records (``sim.compare.trace_bits``): fp32 with one lane and fp16 with two (the RTL's fitting designs), on
the pile and the stack in the hazard order, cold and warm-started (random initial impulses, seed printed, SEED=
overrides), 4 and 2 passes per fetch; the sweep order (a banded order: a small lag, many empty lanes); a ring smaller
than a fetch (the records wrap around it); four lanes (fp16); the kinds interleaved (1 pass per fetch). The argument
check: fetches that would serve contact and friction passes together end the step at once (error 3, nothing issued, no
stream read). Lanes that share a dynamic body (a host without the lane plan): the later lane is rejected in every pass
(error 4), and the step equals the golden model's without those manifolds.

The tests can fail: the kernel with the impulse ring's read skipped (every pass starting from the record's impulses:
a variant of pgs_kernel.cpp built in the test's directory) differs, and so does a lag below the band width D (the
passes then overtake the sequential order); the C++ refuses the combinations it does not support (static_assert).
"""

from __future__ import annotations

import dataclasses
import subprocess
from pathlib import Path

import numpy as np
import pytest

from hls_export.csim import (CXXFLAGS, HLS_DIR, SOURCES, WINDOW_LANES, build_csim, compile_cpp, csim_defines,
                             impulse_out_records, run_csim_step, run_written_step, warm_start, window_build, window_job)
from hls_export.tests.csim_checks import assert_bit_exact
from models.timing.platforms import get_preset
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import FP16, FP32
from models.kernel.register_map import OFFSET
from models.order.manifold_schedule import band_width
from sim.drive.harness_run import run_harness, write_inputs
from sim.compile.kernel_build import KernelBuild
from sim.drive.kernel_step import golden_step
from sim.compare.trace_bits import Comparison, compare_body_out, compare_impulse_out, compare_trace_bits, read_trace
from sim.drive.seed import run_seed

DESIGNS = {"fp32-1lane": (FP32, 1), "fp16-2lanes": (FP16, 2)}
assert all(WINDOW_LANES[fmt.name] == lanes for fmt, lanes in DESIGNS.values())


def _seed() -> int:
    return run_seed()


def _job(design: str, scene: str, start: str = "cold", schedule: str = "hazard", fetch: int | None = None,
         interleaved: bool = False) -> KernelJob:
    fmt, lanes = DESIGNS[design]
    cold = window_job(scene, fmt, lanes, schedule, 4, fetch, interleaved)
    return cold if start == "cold" else _warm(cold)


def _warm(cold: KernelJob) -> KernelJob:
    """``cold`` warm-started: random initial impulses of the seed (printed; SEED= overrides)."""
    print(f"\nwarm start seed {_seed()} (SEED={_seed()} reproduces)")
    return cold.impulses_travelling(warm_start(cold, _seed()))


def _check(job: KernelJob, tmp_path: Path, label: str) -> None:
    kb = window_build(job)
    res = run_csim_step(job, tmp_path, build_csim(kb), kb)
    plan = job.record_window
    assert plan is not None
    assert_bit_exact(res, job, f"window {label}, {len(job.slots)} slots ({plan.empty_lanes} empty lanes), lag "
                     f"{plan.lag}, {plan.fetch_passes} passes per fetch",
                     f"{int(res.registers['impulse_out_records'])} impulse-out records compared; csim "
                     f"{res.registers['wall_s']:.3f} s, golden {res.golden_seconds:.2f} s")
    assert int(res.registers["impulse_out_records"]) == impulse_out_records(job) == \
        plan.fetches(job.params) * len(job.slots) // plan.lanes


@pytest.mark.xfail(strict=True, raises=(AssertionError, pytest.fail.Exception),
                   reason="the C++ solves every manifold-pass, where the RTL rejects the records whose impulse words "
                          "turned non-finite (error 5) and the golden model follows the RTL (KernelJob.record_checks; "
                          "hls_export/README.md)")
@pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")  # the golden model's NaNs: the point
@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")
@pytest.mark.parametrize("design", list(DESIGNS))
def test_csim_window_at_extremes(design: str, tmp_path: Path) -> None:
    """The fitting designs' C++ at extreme magnitudes (``models.kernel.extreme_stimulus``, the run seed): a known
    failure, marked strict, so that the day the C++ follows the RTL's rejection this test reports it."""
    from models.kernel.extreme_stimulus import extreme_magnitudes

    job = extreme_magnitudes(_job(design, "pile"), _seed())
    if golden_step(job).solved.rejected_passes == 0:  # not an AssertionError: the reason must hold, or it fails
        raise RuntimeError(f"seed {_seed()}: the golden model rejects no manifold-pass; the known failure's reason "
                           "does not hold on this step")
    _check(job, tmp_path, f"{design} pile at extremes, seed {_seed()}")


@pytest.mark.parametrize("fetch", [4, 2])
@pytest.mark.parametrize("start", ["cold", "warm"])
@pytest.mark.parametrize("scene", ["pile", "stack"])
@pytest.mark.parametrize("design", list(DESIGNS))
def test_csim_window_bit_exact(design: str, scene: str, start: str, fetch: int, tmp_path: Path) -> None:
    job = _job(design, scene, start, fetch=fetch)
    assert job.record_window is not None and job.record_window.fetch_passes == fetch
    _check(job, tmp_path, f"{design} {scene}/hazard {start} {fetch} passes per fetch")


@pytest.mark.parametrize("scene", ["pile", "stack"])
def test_csim_window_sweep_empty_lanes(scene: str, tmp_path: Path) -> None:
    """The sweep order, two lanes: many records closed with an empty lane (all-ones header, zero words)."""
    job = _job("fp16-2lanes", scene, "warm", schedule="sweep")
    assert job.record_window is not None and job.record_window.empty_lanes > 0
    _check(job, tmp_path, f"fp16-2lanes {scene}/sweep warm")


@pytest.mark.parametrize("design", list(DESIGNS))
def test_csim_window_ring_wraps(design: str, tmp_path: Path) -> None:
    """A ring of 64 records (PGS_WINDOW=64) on the pile's 108 slots in the sweep order: the fetch's records wrap
    around the ring (and the impulse ring) while its passes trail each other, as many as fit."""
    fmt, lanes = DESIGNS[design]
    job = _warm(window_job("pile", fmt, lanes, "sweep", depth=64))
    plan = job.record_window
    assert plan is not None and len(job.slots) // lanes > plan.depth and plan.fetch_passes >= 2
    _check(job, tmp_path, f"{design} pile/sweep warm, ring of {plan.depth}")


def test_csim_window_four_lanes(tmp_path: Path) -> None:
    """PGS_LANES = 4 (the RTL's fastest fitting design has four lanes in fp16): the pile, warm-started."""
    _check(_warm(window_job("pile", FP16, 4)), tmp_path, "fp16-4lanes pile/hazard warm")


def test_csim_window_interleaved(tmp_path: Path) -> None:
    """Contact and friction passes alternate: one pass per fetch, each friction fetch reading the lam its contact
    fetch just wrote."""
    job = _job("fp16-2lanes", "pile", "warm", fetch=1, interleaved=True)
    _check(job, tmp_path, "fp16-2lanes pile/hazard interleaved warm")


@pytest.mark.parametrize("fetch,interleaved", [(3, False), (2, True)], ids=["fetch3-of-4", "fetch2-interleaved"])
def test_csim_window_mixed_fetch_refused(fetch: int, interleaved: bool, tmp_path: Path) -> None:
    """A fetch that would serve both kinds: the argument check (error code 3 alone), the step ends at once: nothing
    issued, no constraint or body beat taken, no trace, body-out or impulse-out record."""
    job = _job("fp16-2lanes", "pile", fetch=1, interleaved=interleaved)
    kb = window_build(job)
    write_inputs(tmp_path, job, kb)
    regs = np.frombuffer((tmp_path / "regs.bin").read_bytes(), dtype="<u4").reshape(-1, 2).copy()
    regs[regs[:, 0] == OFFSET["fetch_passes"], 1] = fetch
    (tmp_path / "regs.bin").write_bytes(regs.tobytes())
    r = run_harness(build_csim(kb), tmp_path, seed=1, preset=get_preset("ideal"), max_cycles=0)
    assert int(r["status"]) == (1 << 2) | (3 << 8), f"status 0x{int(r['status']):x}: expected error code 3 alone"
    assert r["issued"] == 0 and r["trace_records"] == 0 and r["body_out_beats"] == 0
    assert r["impulse_out_records"] == 0 and r["cons_beats_taken"] == 0 and r["body_in_beats_taken"] == 0
    with pytest.raises(ValueError, match="one kind"):
        _job("fp16-2lanes", "pile", fetch=fetch, interleaved=interleaved)


def test_csim_window_lanes_collide(tmp_path: Path) -> None:
    """The host pairs consecutive manifolds of the sweep order into records without the lane plan: the kernel
    rejects the later lane of each record whose lanes share a dynamic body, in every pass (error code 4 alone), so
    that no two lanes write one body; the trace, the body-out stream and the impulse-out records (zeros for a
    rejected lane) then equal the golden model's step without those manifolds, bit for bit."""
    job = _job("fp16-2lanes", "pile", schedule="sweep")  # consecutive manifolds of the sweep often share a body
    plan = job.record_window
    assert plan is not None
    dyn, cons = job.bodies.dynamic, job.cons
    assert plan.lanes == 2
    order = job.slots[job.slots >= 0]
    naive = np.concatenate([order, np.full(len(order) % 2, -1)])

    def dynamic_bodies(m: int) -> set[int]:
        return set() if m < 0 else {int(b) for b in (cons.body_a[m], cons.body_b[m]) if dyn[b]}

    # what the kernel does: lane 1 of a record goes where it shares a dynamic body with lane 0
    kept = naive.copy()
    kept.reshape(-1, 2)[[bool(dynamic_bodies(a) & dynamic_bodies(b)) for a, b in naive.reshape(-1, 2)], 1] = -1
    collisions = int(np.count_nonzero(kept != naive))
    assert collisions >= 1
    lag = band_width(naive, cons, dyn, plan.lanes)
    sent = dataclasses.replace(job, record_window=dataclasses.replace(plan, slots=naive, lag=lag, band=lag))
    kb = window_build(sent)
    write_inputs(tmp_path, sent, kb)
    r = run_harness(build_csim(kb), tmp_path, seed=1, preset=get_preset("ideal"), max_cycles=0)
    passes = 2 * job.params.iterations
    print(f"\n[lanes collide] {collisions} of {len(naive) // plan.lanes} records collide; status "
          f"0x{int(r['status']):x}, issued {int(r['issued'])}")
    assert int(r["status"]) == (1 << 3) | (4 << 8), f"status 0x{int(r['status']):x}: expected error code 4 alone"
    assert int(r["issued"]) == passes * int(np.count_nonzero(kept >= 0))
    expected = dataclasses.replace(sent, schedule=kept, record_window=dataclasses.replace(sent.record_window,
                                                                                          slots=kept))
    golden = golden_step(expected)
    cmp = Comparison()
    compare_trace_bits(read_trace(tmp_path / "trace.bin", job.fmt, kb.trace_bytes), golden.records, expected, cmp)
    compare_body_out(tmp_path, expected, kb, golden.final, cmp)
    compare_impulse_out(tmp_path, expected, golden.records, cmp)
    assert cmp.first_mismatch is None and cmp.differing_bits == 0, cmp.first_mismatch
    assert cmp.records == expected.manifold_passes


# --- the comparison catches a wrong kernel ---------------------------------------------------------------------
RING_READ = "return first ? from_record : from_ring;"  # pgs_kernel.cpp start_impulse


def _ring_read_skipped(kb: KernelBuild, out: Path) -> Path:
    """The testbench built with a variant of pgs_kernel.cpp (in ``out``, never in hls_export/) whose passes all
    start from the record's impulses: the impulse ring is written but never read."""
    src = (HLS_DIR / "pgs_kernel.cpp").read_text()
    assert src.count(RING_READ) == 1
    out.mkdir(parents=True, exist_ok=True)
    (out / "pgs_kernel.cpp").write_text(src.replace(RING_READ, "return (void)first, (void)from_ring, from_record;"))
    return compile_cpp([out / "pgs_kernel.cpp", HLS_DIR / "pgs_csim_main.cpp"], out / "pgs_csim", csim_defines(kb))


@pytest.mark.parametrize("design", list(DESIGNS))
def test_csim_window_fault_ring_read_skipped(design: str, tmp_path: Path) -> None:
    """Without the impulse ring every pass after a fetch's first restarts from the fetch's impulses: the second
    contact pass's first record already differs (trace), and so do the body-out stream and the impulse-out records."""
    job = _job(design, "pile", "warm")
    kb = window_build(job)
    res = run_csim_step(job, tmp_path / "run", _ring_read_skipped(kb, tmp_path / "variant"), kb)
    c = res.comparison
    print(f"\n[{design} pile warm, impulse ring read skipped] {c.differing_bits} differing bits; {c.first_mismatch}")
    assert not res.bit_exact and c.differing_bits > 0
    assert "contact pass, iteration 1" in str(c.first_mismatch)


def test_csim_window_fault_lag_below_band(tmp_path: Path) -> None:
    """lag = 1 on the pile (D > 1): a pass updates a body before the pass ahead of it is done with it, so the
    result is not the sequential solve's (the kernel cannot check lag; the host computes it)."""
    job = _job("fp32-1lane", "pile")
    assert job.record_window is not None and job.record_window.band > 1
    kb = window_build(job)
    write_inputs(tmp_path, job, kb)
    regs = np.frombuffer((tmp_path / "regs.bin").read_bytes(), dtype="<u4").reshape(-1, 2).copy()
    regs[regs[:, 0] == OFFSET["lag"], 1] = 1
    (tmp_path / "regs.bin").write_bytes(regs.tobytes())
    res = run_written_step(job, tmp_path, build_csim(kb), kb)
    print(f"\n[lag 1 < D = {job.record_window.band}] {res.comparison.first_mismatch}")
    assert not res.bit_exact and "iteration 0" in str(res.comparison.first_mismatch)


@pytest.mark.parametrize("defines,message", [
    (["-DPGS_IMPULSES_IN_RECORDS=0"], "impulses in the records only"),
    (["-DPGS_IMPULSES_IN_RECORDS=1", "-DPGS_TANGENTS_ON_CHIP=1"], "streams the friction tangents"),
    (["-DPGS_IMPULSES_IN_RECORDS=1", "-DPGS_SOFT_CONTACT=1"], "configuration of the streaming kernel"),
    (["-DPGS_IMPULSES_IN_RECORDS=1", "-DPGS_LANES=3"], "PGS_LANES must be 1, 2 or 4"),
    (["-DPGS_IMPULSES_IN_RECORDS=1", "-DPGS_WINDOW=1000"], "power of two"),
], ids=["impulses-on-chip", "tangents-on-chip", "soft-contact", "three-lanes", "ring-not-a-power-of-two"])
def test_the_cpp_refuses_unsupported_windows(defines: list[str], message: str) -> None:
    """The C++ stops what the window kernel does not support at compile time (static_assert; -fsyntax-only)."""
    cmd = ["g++", *CXXFLAGS, "-DPGS_FORCE_SHIMS", "-DPGS_WINDOW=1024", *defines, f"-I{HLS_DIR}", "-fsyntax-only",
           *map(str, SOURCES)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode != 0
    assert "static assertion failed" in proc.stderr and message in proc.stderr, proc.stderr[-2000:]


@pytest.mark.parametrize("kb,match", [(KernelBuild(FP32, window=1024), "impulses in the records only"),
                                      (KernelBuild(FP16, window=1024, lanes=8, impulses_in_records=True),
                                       "1, 2 or 4")],
                         ids=["impulses-on-chip", "eight-lanes"])
def test_build_csim_refuses_unsupported_windows(kb: KernelBuild, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        build_csim(kb)


def test_lanes_without_the_window_are_refused_before_a_build() -> None:
    with pytest.raises(ValueError, match="above 1 only with the window kernel"):
        KernelBuild(FP32, lanes=2, impulses_in_records=True)


def test_window_formats_are_the_fitting_designs() -> None:
    """fp32 one lane (2 beats a lane record), fp16 two (1 beat each: a window record of 2 beats)."""
    for design, (fmt, lanes) in DESIGNS.items():
        kb = window_build(_job(design, "stack"))
        assert (kb.lanes, kb.layout.window_beats) == (lanes, 2 if fmt == FP32 else 1), design
