"""C simulation of the HLS kernel's records design with the tangent basis derived on chip (PGS_TANGENTS_ON_CHIP=1
with PGS_IMPULSES_IN_RECORDS=1, the RTL's TANGENTS_ON_CHIP): the friction record carries no t0, t1 (n, c,
f_jac_inv, then lam[0..3], lamT[0..1]: the word offsets of generated/pgs_stream_layout.h, from
models/kernel/stream_format.py), and the friction pass derives them from n in the format (pgs_solver.h plane_space,
models/setup/tangent_basis.py plane_space_in operation for operation). Against the golden model of
``KernelJob.tangents_derived()`` bit for bit in the trace, the body-out stream and the impulse-out records: binary16
and binary32 on the pile and the stack, cold and warm-started (random initial impulses, seed printed, SEED=
overrides).

The derivation alone (hls_export/tests/tangent_basis_main.cpp, pgs_solver.h plane_space) against plane_space_in
bit for bit in binary16 and binary32 on normals the scenes do not reach: the pile's and the stack's normals all take
the x branch (|n_z| below the split), so random unit normals of both branches, normals at the split, axis-aligned ones
with signed zeros, unnormalised ones, random bit patterns and the specials (zero normal, infinities, NaN).

The tests can fail: the derived basis is not the host's float64 one rounded to the format, and this build's run on
the pile differs from the golden model of the same step with the host's streamed tangents; the records build
without the option reads the tangent-less records wrongly; and the C++ refuses the option without the impulses in
the records, with the full inverse inertia and with the friction-coefficient word (static_assert; ``build_csim``
refuses the first before compiling).
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest

from hls_export.csim import (BUILD_ROOT, CXXFLAGS, HLS_DIR, RECORDS_FORMATS, RECORDS_SCENES, SOURCES, build_csim,
                             compile_cpp, records_build, run_csim_step, run_written_step, scene_job, warm_start)
from hls_export.tests.csim_checks import assert_bit_exact
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import FP16, FP32, NumberFormat
from models.setup.tangent_basis import PLANE_SPACE_SPLIT, plane_space_in
from sim.drive.harness_run import write_inputs
from sim.compile.kernel_build import KernelBuild, default_window
from sim.drive.kernel_step import golden_step
from sim.compare.trace_bits import Comparison, compare_impulse_out, compare_trace_bits, read_trace
from sim.drive.seed import run_seed


def _seed() -> int:
    return run_seed()


def _job(scene: str, fmt_name: str, start: str = "cold", tangents: bool = True) -> KernelJob:
    """The records design's step of ``scene`` (with the tangents derived on chip, or streamed: the host's)."""
    job = scene_job(scene, "hazard", 4, records_build(RECORDS_FORMATS[fmt_name], tangents_on_chip=tangents))
    if start == "warm":
        seed = _seed()
        print(f"\nwarm start seed {seed} (SEED={seed} reproduces)")
        job = job.impulses_travelling(warm_start(job, seed))
    return job


@pytest.mark.parametrize("start", ["cold", "warm"])
@pytest.mark.parametrize("scene", RECORDS_SCENES)
@pytest.mark.parametrize("fmt_name", list(RECORDS_FORMATS))
def test_csim_tangents_bit_exact(fmt_name: str, scene: str, start: str, tmp_path: Path) -> None:
    job = _job(scene, fmt_name, start)
    kb = records_build(job.fmt, job)
    assert job.tangents_on_chip and job.impulses_in_records and kb.tangents_on_chip and kb.impulses_in_records
    res = run_csim_step(job, tmp_path, build_csim(kb), kb, default_window(job.fmt, kb.cons_bits))
    assert_bit_exact(res, job, f"tangents on chip {fmt_name} {scene} {start}",
                     f"{int(res.registers['impulse_out_records'])} impulse-out records compared; friction record "
                     f"{kb.layout.friction_bits} bits, {kb.layout.friction_beats} beat(s); csim "
                     f"{res.registers['wall_s']:.3f} s, golden {res.golden_seconds:.2f} s")
    assert int(res.registers["impulse_out_records"]) == job.manifold_passes


@pytest.mark.parametrize(("fmt_name", "tangents"), [("fp32", True), ("fp16", False)])
def test_csim_with_256_bit_body_streams(fmt_name: str, tangents: bool, tmp_path: Path) -> None:
    """The fastest fitting designs' body streams (make sim BODY_BITS=256: fp32 with the tangents derived, fp16 with
    the tangents streamed): PGS_BODY_IN_W = PGS_BODY_OUT_W = 256, two body-in beats and one body-out beat per body
    in fp16 (three and two in fp32), bit-exact on the pile."""
    fmt = RECORDS_FORMATS[fmt_name]
    job = scene_job("pile", "hazard", 4, records_build(fmt, tangents_on_chip=tangents, body_bits=256))
    kb = records_build(fmt, job, body_bits=256)
    assert (kb.body_in_bits, kb.body_out_bits, kb.tangents_on_chip) == (256, 256, tangents)
    assert (kb.layout.body_in_beats, kb.layout.body_out_beats) == ((3, 2) if fmt_name == "fp32" else (2, 1))
    res = run_csim_step(job, tmp_path, build_csim(kb), kb, default_window(fmt, kb.cons_bits))
    if res.comparison.first_mismatch is not None:
        pytest.fail(res.comparison.first_mismatch)
    assert res.bit_exact and res.comparison.bodies == job.bodies.num_bodies


def test_the_friction_record_has_no_tangents() -> None:
    """The build's friction record is StreamLayout's without t0, t1: fp32 512 bits (one 512-bit beat, two with the
    tangents), fp16 288 bits (one beat either way)."""
    for fmt, with_t, without_t in ((FP32, 704, 512), (FP16, 384, 288)):
        streamed, derived = records_build(fmt).layout, records_build(fmt, tangents_on_chip=True).layout
        assert (streamed.friction_bits, derived.friction_bits) == (with_t, without_t)
        assert derived.friction_lam_word == streamed.friction_lam_word - 6
    assert records_build(FP32, tangents_on_chip=True).layout.friction_beats == 1
    assert records_build(FP32).layout.friction_beats == 2


@pytest.mark.parametrize("fmt_name", list(RECORDS_FORMATS))
def test_the_derived_basis_differs_from_the_host_one(fmt_name: str, tmp_path: Path) -> None:
    """The bit-exact runs above tell the two bases apart: on the pile the derived tangents are not the host's float64
    basis rounded to the format, and this build's trace, body-out and impulse-out records differ from the golden
    model of the same step with the streamed (host) tangents."""
    derived, streamed = _job("pile", fmt_name), _job("pile", fmt_name, tangents=False)
    assert not np.array_equal(derived.cons.tangent, streamed.cons.tangent)
    np.testing.assert_allclose(derived.cons.tangent, streamed.cons.tangent, atol=4.0 * 2.0 ** -derived.fmt.man_bits)
    kb = records_build(derived.fmt, derived)
    res = run_csim_step(derived, tmp_path, build_csim(kb), kb)
    assert res.bit_exact
    host = golden_step(streamed)
    cmp = Comparison()
    compare_trace_bits(read_trace(tmp_path / "trace.bin", derived.fmt, kb.trace_bytes), host.records, streamed, cmp)
    compare_impulse_out(tmp_path, streamed, host.records, cmp)
    print(f"\n[{fmt_name} pile, this build against the streamed tangents' golden model] {cmp.differing_bits} differing "
          f"bits; first: {cmp.first_mismatch}")
    assert cmp.differing_bits > 0 and cmp.first_mismatch is not None


def test_the_records_build_misreads_the_tangent_less_records(tmp_path: Path) -> None:
    """fp16, where the friction record is one beat with or without t0, t1: the records build without the option
    run on this layout's records (its word offsets: f_jac_inv and the impulses read from the wrong words) differs."""
    job = _job("pile", "fp16", "warm")
    kb = records_build(job.fmt, job)
    assert kb.layout.friction_beats == records_build(job.fmt).layout.friction_beats == 1
    write_inputs(tmp_path, job, kb)
    res = run_written_step(job, tmp_path, build_csim(records_build(job.fmt)), kb)
    print(f"\n[fp16 pile, tangent-less records through the build without the option] {res.comparison.first_mismatch}")
    assert not res.bit_exact


@pytest.mark.parametrize("defines,message", [
    (["-DPGS_IMPULSES_IN_RECORDS=0"], "build it with PGS_IMPULSES_IN_RECORDS = 1"),
    (["-DPGS_IMPULSES_IN_RECORDS=1", "-DPGS_MU_W=1"], "PGS_MU_W = 0"),
    (["-DPGS_IMPULSES_IN_RECORDS=1", "-DPGS_IINV_W=6"], "PGS_IINV_W = 3"),
    (["-DPGS_IMPULSES_IN_RECORDS=1", "-DPGS_TANGENTS_ON_CHIP=2"], "must be 0 or 1"),
], ids=["impulses-on-chip", "mu-word", "full-inertia", "not-a-bit"])
def test_the_cpp_refuses_bad_combinations(defines: list[str], message: str) -> None:
    """The C++ stops a bad combination at compile time (static_assert in pgs_stream.h; -fsyntax-only: no build)."""
    cmd = ["g++", *CXXFLAGS, "-DPGS_FORCE_SHIMS", "-DPGS_TANGENTS_ON_CHIP=1", *defines, f"-I{HLS_DIR}",
           "-fsyntax-only", *map(str, SOURCES)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode != 0
    assert "static assertion failed" in proc.stderr and message in proc.stderr, proc.stderr[-2000:]


def test_build_csim_refuses_the_option_without_the_records() -> None:
    with pytest.raises(ValueError, match="records design only"):
        build_csim(KernelBuild(FP32, tangents_on_chip=True))


def _normals(fmt: NumberFormat, rng: np.random.Generator) -> np.ndarray:
    """(K, 3) word patterns of ``fmt``: random unit normals, normals at the split (|n_z| the rounded constant and its
    neighbours), axis-aligned ones with signed zeros, unnormalised ones, random bit patterns and specials."""
    unit = rng.normal(size=(20000, 3))
    unit /= np.linalg.norm(unit, axis=1, keepdims=True)
    split = int(fmt.encode(np.array([fmt.round(PLANE_SPACE_SPLIT)]))[0])
    at_split = rng.normal(size=(600, 3))
    at_split[:, 2] = np.repeat(fmt.decode(np.array([split - 1, split, split + 1], dtype=np.uint64)), 200)
    at_split[::2, 2] *= -1
    axes = [[s * (k == i) for k in range(3)] for i in range(3) for s in (1.0, -1.0)]
    signed = [[a if a else z for a, z in zip(ax, zs)] for ax in axes for zs in ((0.0, 0.0, 0.0), (-0.0, -0.0, -0.0))]
    specials = [[0.0, 0.0, 0.0], [-0.0, 0.0, -0.0], [np.inf, 0.0, 0.0], [0.0, 0.0, -np.inf], [np.nan, 0.0, 1.0],
                [0.0, np.nan, 0.0], [1.0, 1.0, 1.0], [0.5, -0.5, 0.5]]
    vals = np.concatenate([unit, at_split, np.array(signed + specials), rng.uniform(-4, 4, (4000, 3))])
    words = fmt.encode(fmt.round(vals)).astype(np.uint32)
    rand = rng.integers(0, 1 << fmt.width, (4000, 3), dtype=np.uint64).astype(np.uint32)
    return np.concatenate([words, rand])


@pytest.mark.parametrize("fmt", [FP32, FP16], ids=["fp32", "fp16"])
def test_plane_space_matches_the_golden(fmt: NumberFormat, tmp_path: Path) -> None:
    exe = compile_cpp([HLS_DIR / "tests" / "tangent_basis_main.cpp"], BUILD_ROOT / f"tangent_basis_{fmt.name}"
                      / "tangent_basis", [f"-DPGS_EXP_BITS={fmt.exp_bits}", f"-DPGS_MAN_BITS={fmt.man_bits}"])
    seed = run_seed()
    words = _normals(fmt, np.random.default_rng(seed))
    (tmp_path / "in.bin").write_bytes(words.astype("<u4").tobytes())
    subprocess.run([str(exe), str(tmp_path / "in.bin"), str(tmp_path / "out.bin")], check=True)
    got = np.frombuffer((tmp_path / "out.bin").read_bytes(), dtype="<u4").reshape(-1, 6)
    n = fmt.decode(words.astype(np.uint64))
    with np.errstate(all="ignore"):
        t0, t1 = plane_space_in(fmt, n)
        use_z = fmt.round(PLANE_SPACE_SPLIT) < np.abs(n[:, 2])
    want = fmt.encode(np.concatenate([t0, t1], axis=1)).astype(np.uint32)
    assert got.shape == want.shape
    bad = np.flatnonzero((got != want).any(axis=1))
    if bad.size:
        i = bad[0]
        print(f"normal {[hex(w) for w in words[i]]}: kernel {[hex(w) for w in got[i]]}, golden "
              f"{[hex(w) for w in want[i]]}")
    print(f"\n{fmt.name}: {len(words):,} normals ({int(use_z.sum()):,} on the z branch; seed {seed}, SEED= overrides): "
          f"{bad.size} differing bases")
    assert bad.size == 0 and use_z.sum() > 1000 and (~use_z).sum() > 1000
